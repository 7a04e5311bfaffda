// SPDX-License-Identifier: MIT
#include "thread_pool.h"

#include "simd_config.h"

#if MODRT_CPU_X86
#include <immintrin.h>
#endif

namespace modrt::cpu {
namespace {

// How long an idle worker (or the caller waiting for workers) polls before it sleeps: a few
// pause instructions, then sched_yield(), which hands the core to another runnable thread
// (the caller, when the pool's threads outnumber the free cores) instead of burning it.
constexpr int kSpin = 256;
constexpr int kPauses = 32;

inline void cpu_relax(int i) {
  if (i >= kPauses) {
    std::this_thread::yield();
    return;
  }
#if MODRT_CPU_X86
  _mm_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

}  // namespace

ThreadPool::ThreadPool(int threads) {
  workers_.reserve(std::size_t(threads > 1 ? threads - 1 : 0));
  try {
    for (int t = 1; t < threads; ++t) workers_.emplace_back([this, t] { worker(t); });
  } catch (...) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& w : workers_) w.join();
    throw;
  }
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& w : workers_) w.join();
}

void ThreadPool::drain(int thread) {
  for (std::size_t i = next_.fetch_add(1, std::memory_order_relaxed); i < count_;
       i = next_.fetch_add(1, std::memory_order_relaxed))
    task_(ctx_, i, thread);
}

void ThreadPool::run(std::size_t count, Task task, void* ctx) {
  if (count == 0) return;
  if (workers_.empty()) {
    for (std::size_t i = 0; i < count; ++i) task(ctx, i, 0);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    task_ = task;
    ctx_ = ctx;
    count_ = count;
    next_.store(0, std::memory_order_relaxed);
    // New generation, open, nobody in it (the previous run ended with no worker inside).
    const std::uint64_t g = std::uint64_t(generation(state_.load(std::memory_order_relaxed)) + 1u);
    state_.store(g << 32, std::memory_order_release);
  }
  wake_.notify_all();
  drain(0);
  // Every index is taken: close the run and wait for the workers that joined it.
  std::uint64_t s = state_.fetch_or(kClosed, std::memory_order_acq_rel);
  for (int i = 0; i < kSpin && (s & kActiveMask) != 0; ++i) {
    cpu_relax(i);
    s = state_.load(std::memory_order_acquire);
  }
  if ((s & kActiveMask) == 0) return;
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [this] { return (state_.load(std::memory_order_acquire) & kActiveMask) == 0; });
}

void ThreadPool::worker(int thread) {
  std::uint32_t seen = 0;
  for (;;) {
    // Spin first: the phases of a frame follow each other within microseconds.
    for (int i = 0; i < kSpin && generation(state_.load(std::memory_order_relaxed)) == seen; ++i)
      cpu_relax(i);
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || generation(state_.load(std::memory_order_relaxed)) != seen; });
      if (stop_) return;
    }
    // Join the current run if it is still open; a worker that comes too late does nothing.
    std::uint64_t s = state_.load(std::memory_order_acquire);
    seen = generation(s);
    bool joined = false;
    while (!(s & kClosed) && generation(s) == seen)
      if (state_.compare_exchange_weak(s, s + 1, std::memory_order_acq_rel, std::memory_order_acquire)) {
        joined = true;
        break;
      }
    if (!joined) continue;
    drain(thread);
    s = state_.fetch_sub(1, std::memory_order_acq_rel);
    if ((s & kClosed) && (s & kActiveMask) == 1) {
      std::lock_guard<std::mutex> lock(mutex_);
      done_.notify_one();
    }
  }
}

}  // namespace modrt::cpu

#include "simd_config_end.h"
