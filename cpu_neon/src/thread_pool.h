// SPDX-License-Identifier: MIT
// modrt::cpu — a fixed pool of worker threads for CpuLevelRuntime (private to cpu_neon).
//
// `threads` - 1 std::thread workers are started once, by the constructor; run() hands them
// an index range and the calling thread works on it too (it is thread 0). Indices are taken
// one at a time from an atomic counter, so which thread runs an index varies from call to
// call: a task must write only outputs that belong to its index (then the results do not
// depend on the thread count). run() allocates nothing: the task is a plain function pointer
// and a context pointer, and the workers sleep on a condition variable between calls (after
// spinning briefly, so that the back-to-back phases of one frame do not pay a wake-up each).
//
// Oversubscription: a worker joins a run only while it is open. When the caller has taken
// the last index it closes the run and waits only for the workers that joined (and so may
// still be running an index), never for one that has not been scheduled yet: on a machine
// whose other cores are busy, run() then costs about what one thread costs.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

namespace modrt::cpu {

class ThreadPool {
 public:
  // task(ctx, index, thread): thread is in [0, threads()); 0 is the caller of run().
  using Task = void (*)(void* ctx, std::size_t index, int thread);

  // Starts threads - 1 workers (threads >= 1). Throws std::system_error when a thread cannot
  // be started (the runtime catches it in create()).
  explicit ThreadPool(int threads);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int threads() const { return int(workers_.size()) + 1; }

  // Runs task(ctx, i, thread) for every i in [0, count) and returns when all have finished.
  // Not reentrant: one run() at a time (the runtime is not shared between threads).
  void run(std::size_t count, Task task, void* ctx);

 private:
  void worker(int thread);
  void drain(int thread);

  // state_: generation (high 32 bits) | closed (bit 31) | workers in the run (low 31 bits).
  static constexpr std::uint64_t kClosed = std::uint64_t(1) << 31;
  static constexpr std::uint64_t kActiveMask = kClosed - 1;
  static std::uint32_t generation(std::uint64_t s) { return std::uint32_t(s >> 32); }

  std::mutex mutex_;
  std::condition_variable wake_, done_;
  Task task_ = nullptr;  // the run's task, written under mutex_ before state_ opens it
  void* ctx_ = nullptr;
  std::size_t count_ = 0;
  std::atomic<std::size_t> next_{0};
  std::atomic<std::uint64_t> state_{kClosed};
  bool stop_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace modrt::cpu
