// SPDX-License-Identifier: MIT
// DRT operators built once (precompute/drt_cache.h, issue 23 item 6): the first call builds
// and saves, the second loads the same bytes; a moved box, another albedo, other build
// settings or another level give another file; a truncated file or one that does not fit the
// objects is rebuilt and replaced (the reason reported); an unwritable cache is an error that
// names the directory.
#include <gtest/gtest.h>

#include <unistd.h>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "drt_test_support.h"
#include "modrt/drt_io.h"
#include "modrt/precompute/drt_cache.h"

namespace modrt::precompute::drt_test {
namespace {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    path_ = fs::temp_directory_path() /
            ("modrt_drt_cache_" + std::to_string(long(::getpid())) + "_" + std::to_string(counter++));
    fs::remove_all(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string str() const { return path_.string(); }

 private:
  fs::path path_;
};

std::vector<std::byte> bytes_of(const DrtOperators& drt) {
  Result<std::vector<std::byte>> b = serialize_drt(drt);
  EXPECT_TRUE(b.ok()) << b.status().to_string();
  return b.ok() ? std::move(b).value() : std::vector<std::byte>{};
}

DrtBuildSettings quick() {
  DrtBuildSettings s;
  s.rays = 64;
  return s;
}

TEST(DrtCache, BuiltOnceThenLoadedAndRebuiltWhenAnythingChanges) {
  const ClutterScene s = two_boxes_in_a_row();
  Result<Level> level = build_level(s.description, dict());
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  TempDir dir;
  std::vector<std::string> log;
  const auto record = [&](const std::string& line) { log.push_back(line); };

  Result<DrtCacheResult> first =
      load_or_build_drt(level.value(), dict(), s.clutter, quick(), dir.str(), record);
  ASSERT_TRUE(first.ok()) << first.status().to_string();
  EXPECT_FALSE(first->loaded);
  ASSERT_TRUE(fs::exists(first->path)) << first->path;
  EXPECT_EQ(first->operators.objects.size(), s.clutter.size());

  Result<DrtCacheResult> second =
      load_or_build_drt(level.value(), dict(), s.clutter, quick(), dir.str(), record);
  ASSERT_TRUE(second.ok()) << second.status().to_string();
  EXPECT_TRUE(second->loaded);
  EXPECT_EQ(second->path, first->path);
  EXPECT_TRUE(second->rebuilt.empty());
  EXPECT_EQ(bytes_of(second->operators), bytes_of(first->operators));

  // Every input is in the name.
  const Result<std::uint64_t> key = drt_cache_key(level.value(), dict().settings, s.clutter, quick());
  ASSERT_TRUE(key.ok());
  EXPECT_EQ(fs::path(first->path).filename().string(), drt_cache_file_name(key.value()));
  std::vector<ClutterObject> moved = s.clutter;
  moved[1].box.center.x += 0.01;
  std::vector<ClutterObject> recoloured = s.clutter;
  recoloured[0].albedo.g = 0.25;
  DrtBuildSettings more_rays = quick();
  more_rays.rays = 128;
  ClutterScene other_level = s;
  other_level.description.blocks[0].albedo[kFaceNegY] = glm::dvec3(0.3);
  Result<Level> level2 = build_level(other_level.description, dict());
  ASSERT_TRUE(level2.ok());
  for (const Result<std::uint64_t>& k :
       {drt_cache_key(level.value(), dict().settings, moved, quick()),
        drt_cache_key(level.value(), dict().settings, recoloured, quick()),
        drt_cache_key(level.value(), dict().settings, s.clutter, more_rays),
        drt_cache_key(level2.value(), dict().settings, s.clutter, quick())}) {
    ASSERT_TRUE(k.ok());
    EXPECT_NE(k.value(), key.value());
  }
  Result<DrtCacheResult> after_move = load_or_build_drt(level.value(), dict(), moved, quick(), dir.str());
  ASSERT_TRUE(after_move.ok());
  EXPECT_FALSE(after_move->loaded);
  EXPECT_NE(after_move->path, first->path);

  // A truncated file is rebuilt and replaced, the reason reported.
  fs::resize_file(first->path, fs::file_size(first->path) / 2);
  Result<DrtCacheResult> repaired =
      load_or_build_drt(level.value(), dict(), s.clutter, quick(), dir.str(), record);
  ASSERT_TRUE(repaired.ok()) << repaired.status().to_string();
  EXPECT_FALSE(repaired->loaded);
  EXPECT_FALSE(repaired->rebuilt.empty());
  EXPECT_EQ(bytes_of(repaired->operators), bytes_of(first->operators));
  Result<DrtCacheResult> again = load_or_build_drt(level.value(), dict(), s.clutter, quick(), dir.str());
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(again->loaded);

  // Operators of other objects under this name (a hash collision, a hand-copied file): refused
  // by their texel counts, rebuilt.
  ASSERT_TRUE(save_drt(first->path, after_move->operators).ok());
  std::vector<ClutterObject> one = {s.clutter[0]};
  const Result<std::uint64_t> one_key = drt_cache_key(level.value(), dict().settings, one, quick());
  ASSERT_TRUE(one_key.ok());
  const std::string one_path = (fs::path(dir.str()) / drt_cache_file_name(one_key.value())).string();
  ASSERT_TRUE(save_drt(one_path, first->operators).ok());
  Result<DrtCacheResult> misfit = load_or_build_drt(level.value(), dict(), one, quick(), dir.str());
  ASSERT_TRUE(misfit.ok()) << misfit.status().to_string();
  EXPECT_FALSE(misfit->loaded);
  EXPECT_NE(misfit->rebuilt.find("objects"), std::string::npos) << misfit->rebuilt;
  EXPECT_EQ(misfit->operators.objects.size(), 1u);
  bool saw_load = false, saw_rebuild = false;
  for (const std::string& l : log) {
    saw_load = saw_load || l.rfind("loaded DRT operators", 0) == 0;
    saw_rebuild = saw_rebuild || l.rfind("rebuilding DRT operators", 0) == 0;
  }
  EXPECT_TRUE(saw_load && saw_rebuild);
}

TEST(DrtCache, NoDirectoryBuildsAndAnUnwritableOneIsNamed) {
  const ClutterScene s = two_boxes_in_a_row();
  Result<Level> level = build_level(s.description, dict());
  ASSERT_TRUE(level.ok());
  Result<DrtCacheResult> plain = load_or_build_drt(level.value(), dict(), s.clutter, quick(), "");
  ASSERT_TRUE(plain.ok());
  EXPECT_TRUE(plain->path.empty());
  EXPECT_FALSE(plain->loaded);
  // A cache "directory" under a regular file cannot be created.
  TempDir dir;
  fs::create_directories(dir.str());
  const std::string file = (fs::path(dir.str()) / "a_file").string();
  std::ofstream(file) << "x";
  const std::string bad = (fs::path(file) / "cache").string();
  Result<DrtCacheResult> r = load_or_build_drt(level.value(), dict(), s.clutter, quick(), bad);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find(bad), std::string::npos) << r.status().to_string();
}

}  // namespace
}  // namespace modrt::precompute::drt_test
