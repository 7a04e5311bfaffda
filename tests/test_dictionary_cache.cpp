// SPDX-License-Identifier: MIT
// The dictionary cache and the file helpers under it (issue 18 item 9): an unwritable cache
// or output is refused before any bake, temporaries of killed savers are removed, and
// concurrent first runs bake once (flock on the cache entry).
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "modrt/file_io.h"
#include "modrt/precompute/dictionary_cache.h"

namespace modrt::precompute {
namespace {

namespace fs = std::filesystem;

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

class CacheDir {
 public:
  CacheDir() {
    static std::atomic<int> counter{0};
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() / ("modrt_cache_" + std::string(info->name()) + "_" +
                                         std::to_string(long(::getpid())) + "_" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~CacheDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::string str() const { return path_.string(); }

 private:
  fs::path path_;
};

void touch(const std::string& path) { std::ofstream(path) << "partial"; }

// A pid that belonged to a process that has exited (and been reaped).
long dead_pid() {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  int status = 0;
  ::waitpid(child, &status, 0);
  return long(child);
}

// The smallest useful bake (a fraction of a second).
DictionarySettings tiny_settings() {
  DictionarySettings s;
  s.res = 2;
  s.kd = 8;
  s.kb = 4;
  s.rays = 64;
  s.prior_grid = 2;
  s.light_samples = 2;
  s.sh_rays = 16;
  s.probe_grid = 1;
  s.lightfield_spatial = 0;
  return s;
}

// Counts the bakes that start (the first stage of shape 0).
BakeProgress counting_progress(std::atomic<int>& bakes, std::chrono::milliseconds stall = {}) {
  BakeProgress p;
  p.on_stage = [&bakes, stall](const std::string& stage, int shape, double) {
    if (stage == "prior" && shape == 0) {
      ++bakes;
      std::this_thread::sleep_for(stall);  // keep the bake running while the other run arrives
    }
  };
  return p;
}

TEST(DictionaryCache, UnwritableCacheIsRefusedBeforeBaking) {
  CacheDir dir;
  // A regular file where the cache directory should be (like --cache-dir /etc/passwd).
  const std::string not_a_dir = dir.file("passwd");
  touch(not_a_dir);
  std::atomic<int> bakes{0};
  const Result<Dictionary> r = load_or_bake_dictionary(tiny_settings(), not_a_dir, counting_progress(bakes));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::io_error);
  EXPECT_EQ(r.status().message(), "dictionary cache: " + not_a_dir + " is not a directory");
  EXPECT_EQ(bakes.load(), 0);
  // Beneath a file: the directory cannot be created.
  const Status below = check_cache_dir(not_a_dir + "/sub");
  EXPECT_FALSE(below.ok());
  EXPECT_TRUE(contains(below.message(), "cannot create directory " + not_a_dir + "/sub")) << below.message();
  if (::geteuid() != 0) {  // permissions do not bind root
    const std::string ro = dir.file("ro");
    fs::create_directories(ro);
    fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec);
    const Result<Dictionary> r2 = load_or_bake_dictionary(tiny_settings(), ro, counting_progress(bakes));
    fs::permissions(ro, fs::perms::owner_all);
    ASSERT_FALSE(r2.ok());
    EXPECT_TRUE(contains(r2.status().message(), "cannot create files in directory " + ro))
        << r2.status().message();
    EXPECT_EQ(bakes.load(), 0);
  }
  EXPECT_TRUE(check_cache_dir(dir.file("new/nested")).ok());  // missing directories are created
  EXPECT_TRUE(fs::is_directory(dir.file("new/nested")));
}

TEST(DictionaryCache, ReadOnlyCacheHoldingTheEntryStillLoads) {
  CacheDir dir;
  std::atomic<int> bakes{0};
  ASSERT_TRUE(load_or_bake_dictionary(tiny_settings(), dir.str(), counting_progress(bakes)).ok());
  EXPECT_EQ(bakes.load(), 1);
  // Loading needs no write access: the fast path reads before checking writability (the
  // directory is made read-only where that binds, i.e. not for root).
  fs::permissions(dir.str(), fs::perms::owner_read | fs::perms::owner_exec);
  const Result<Dictionary> again =
      load_or_bake_dictionary(tiny_settings(), dir.str(), counting_progress(bakes));
  fs::permissions(dir.str(), fs::perms::owner_all);
  ASSERT_TRUE(again.ok()) << again.status().to_string();
  EXPECT_EQ(bakes.load(), 1);
}

TEST(DictionaryCache, ConcurrentFirstRunsBakeOnce) {
  CacheDir dir;
  std::atomic<int> bakes{0};
  std::mutex log_mutex;
  std::vector<std::string> logs;
  auto run = [&] {
    // Each call opens its own descriptor of the lock file, as two processes would.
    return load_or_bake_dictionary(tiny_settings(), dir.str(),
                                   counting_progress(bakes, std::chrono::milliseconds(300)),
                                   [&](const std::string& m) {
                                     const std::lock_guard<std::mutex> lock(log_mutex);
                                     logs.push_back(m);
                                   });
  };
  Result<Dictionary> a = Status::error(ErrorCode::internal_error, "not run");
  Result<Dictionary> b = a;
  std::thread ta([&] { a = run(); });
  std::thread tb([&] { b = run(); });
  ta.join();
  tb.join();
  ASSERT_TRUE(a.ok()) << a.status().to_string();
  ASSERT_TRUE(b.ok()) << b.status().to_string();
  EXPECT_EQ(bakes.load(), 1);  // the second waited on the lock, then loaded the first's file
  EXPECT_EQ(a->settings, b->settings);
  EXPECT_EQ(a->shapes[0].Ub.data, b->shapes[0].Ub.data);
  int loaded = 0;
  for (const std::string& m : logs) loaded += contains(m, "loaded cached dictionary");
  EXPECT_EQ(loaded, 1);
}

TEST(DictionaryCache, StaleTemporariesOfDeadProcessesAreRemoved) {
  CacheDir dir;
  const std::string entry = cache_file_name(tiny_settings());
  const std::string stale = dir.file(entry + ".tmp." + std::to_string(dead_pid()) + ".0");
  // A counter far above any this process reaches: write_file_atomic's own temporaries count up
  // from 0 per process, and one equal to this would collide with it (O_EXCL).
  const std::string live = dir.file(entry + ".tmp." + std::to_string(long(::getpid())) + ".999999999");
  const std::string other = dir.file("notes.tmp.txt");  // not a temporary of ours
  touch(stale);
  touch(live);
  touch(other);
  std::atomic<int> bakes{0};
  ASSERT_TRUE(load_or_bake_dictionary(tiny_settings(), dir.str(), counting_progress(bakes)).ok());
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(live));  // a save in progress (this process is alive)
  EXPECT_TRUE(fs::exists(other));
  EXPECT_TRUE(fs::exists(dir.file(entry)));
}

// The interface basis (shaped blocks' interfaces): saved beside every dictionary the cache
// bakes, loaded without a bake; a cache without it (or with a damaged one) re-bakes, and the
// re-bake's dictionary is the cached one bit for bit (the bake is deterministic).
TEST(DictionaryCache, InterfaceBasisIsSavedBesideTheDictionaryAndRebakedWhenMissing) {
  CacheDir dir;
  DictionarySettings s = tiny_settings();
  s.lightfield_spatial = 2;
  s.lightfield_directional = 3;
  s.lightfield_supersample = 1;
  s.krlf = 4;
  s.kr = 4;
  s.response_rays = 16;
  std::atomic<int> bakes{0};
  const Result<Dictionary> dict = load_or_bake_dictionary(s, dir.str(), counting_progress(bakes));
  ASSERT_TRUE(dict.ok()) << dict.status().to_string();
  const std::string basis_path = dir.file(interface_basis_file_name(s));
  ASSERT_TRUE(fs::exists(basis_path));
  const Result<Matrix> first = load_or_bake_interface_basis(s, dir.str(), counting_progress(bakes));
  ASSERT_TRUE(first.ok()) << first.status().to_string();
  EXPECT_EQ(bakes.load(), 1);  // loaded, not baked
  EXPECT_EQ(first->rows, 2u * 2u * 3u * 3u);
  EXPECT_EQ(first->cols, 4u);
  // Damaged: re-baked, the same basis, and the dictionary left as it was.
  const auto dictionary_time = fs::last_write_time(dir.file(cache_file_name(s)));
  fs::resize_file(basis_path, fs::file_size(basis_path) - 3);
  const Result<Matrix> again = load_or_bake_interface_basis(s, dir.str(), counting_progress(bakes));
  ASSERT_TRUE(again.ok()) << again.status().to_string();
  EXPECT_EQ(bakes.load(), 2);
  EXPECT_EQ(again->data, first->data);
  EXPECT_EQ(fs::last_write_time(dir.file(cache_file_name(s))), dictionary_time);
  // Without interfaces there is no basis to ask for.
  const Result<Matrix> none = load_or_bake_interface_basis(tiny_settings(), dir.str());
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.status().code(), ErrorCode::invalid_argument);
}

TEST(FileIo, RemoveStaleTemporariesKeepsLiveAndForeignFiles) {
  CacheDir dir;
  const long dead = dead_pid();
  const std::string a_dead = dir.file("a.modrt.tmp." + std::to_string(dead) + ".0");
  const std::string b_dead = dir.file("b.modrt.tmp." + std::to_string(dead) + ".3");
  const std::string a_live = dir.file("a.modrt.tmp." + std::to_string(long(::getpid())) + ".1");
  const std::string odd = dir.file("a.modrt.tmp.12x.0");
  for (const std::string& p : {a_dead, b_dead, a_live, odd}) touch(p);
  EXPECT_EQ(remove_stale_temporaries(dir.str(), "a.modrt"), 1u);  // only a's
  EXPECT_FALSE(fs::exists(a_dead));
  EXPECT_TRUE(fs::exists(b_dead));
  EXPECT_EQ(remove_stale_temporaries(dir.str()), 1u);  // every file's
  EXPECT_FALSE(fs::exists(b_dead));
  EXPECT_TRUE(fs::exists(a_live));
  EXPECT_TRUE(fs::exists(odd));
  // A save removes the stale temporaries of its own file.
  const std::string c_dead = dir.file("c.modrt.tmp." + std::to_string(dead) + ".0");
  touch(c_dead);
  const std::byte data[3] = {std::byte{1}, std::byte{2}, std::byte{3}};
  ASSERT_TRUE(write_file_atomic(dir.file("c.modrt"), data).ok());
  EXPECT_FALSE(fs::exists(c_dead));
}

TEST(FileIo, CheckWritableFileNamesThePath) {
  CacheDir dir;
  EXPECT_TRUE(check_writable_file(dir.file("out/level.modrtlevel")).ok());
  const Status is_dir = check_writable_file(dir.str());
  ASSERT_FALSE(is_dir.ok());
  EXPECT_EQ(is_dir.message(), dir.str() + ": cannot write: is a directory");
  touch(dir.file("f"));
  const Status under_file = check_writable_file(dir.file("f") + "/x.modrt");
  ASSERT_FALSE(under_file.ok());
  EXPECT_EQ(under_file.message(), dir.file("f") + "/x.modrt: " + dir.file("f") + " is not a directory");
  // Nothing is left behind by the probe.
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir.str())) ++entries;
  EXPECT_EQ(entries, 2u);  // "out" and "f"
}

TEST(FileIo, FileLockExcludesAnotherDescriptor) {
  CacheDir dir;
  const std::string lock_path = dir.file("entry.lock");
  std::atomic<bool> second_held{false};
  Result<FileLock> first = FileLock::acquire(lock_path);
  ASSERT_TRUE(first.ok()) << first.status().to_string();
  std::thread t([&] {
    Result<FileLock> second = FileLock::acquire(lock_path);
    second_held = second.ok();
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_FALSE(second_held.load());  // still waiting
  { FileLock release = std::move(first.value()); }
  t.join();
  EXPECT_TRUE(second_held.load());
  const Result<FileLock> bad = FileLock::acquire(dir.file("missing/dir/x.lock"));
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(contains(bad.status().message(), "cannot open lock file")) << bad.status().message();
}

}  // namespace
}  // namespace modrt::precompute
