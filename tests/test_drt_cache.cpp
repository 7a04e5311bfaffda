// SPDX-License-Identifier: MIT
// DRT operators built once (precompute/drt_cache.h, issue 23 item 6): the first call builds
// and saves, the second loads the same bytes; a moved box, another albedo, other build
// settings or another level give another file; a truncated file or one that does not fit the
// objects is rebuilt and replaced (the reason reported); an unwritable cache is an error that
// names the directory. The build state kept next to the operators (drt_state_io.h): written
// and read back byte for byte, for boxes and meshes and every pass; a start after one object
// moved re-traces that object alone and gives a full build's operators, the next start loads
// them; damaged state files are refused naming the file and the part, and replaced.
#include <gtest/gtest.h>

#include <unistd.h>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>
#include <vector>

#include "binary_test_support.h"
#include "drt_test_support.h"
#include "modrt/dictionary_io.h"
#include "modrt/drt_io.h"
#include "modrt/file_io.h"
#include "modrt/precompute/drt_cache.h"
#include "modrt/precompute/drt_state_io.h"

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

std::vector<std::byte> state_bytes(const DrtBuildState& state, std::uint64_t key = 0) {
  Result<std::vector<std::byte>> b = serialize_drt_build_state(state, key);
  EXPECT_TRUE(b.ok()) << b.status().to_string();
  return b.ok() ? std::move(b).value() : std::vector<std::byte>{};
}

void expect_same_operators(const DrtOperators& a, const DrtOperators& b, const std::string& what) {
  ASSERT_EQ(a.objects.size(), b.objects.size()) << what;
  for (std::size_t k = 0; k < a.objects.size(); ++k)
    EXPECT_TRUE(operators_equal(a.objects[k], b.objects[k])) << what << ", object " << k;
  EXPECT_EQ(bytes_of(a), bytes_of(b)) << what;
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
  EXPECT_EQ(first->source, DrtCacheSource::built);
  ASSERT_TRUE(fs::exists(first->path)) << first->path;
  EXPECT_EQ(first->operators.objects.size(), s.clutter.size());

  Result<DrtCacheResult> second =
      load_or_build_drt(level.value(), dict(), s.clutter, quick(), dir.str(), record);
  ASSERT_TRUE(second.ok()) << second.status().to_string();
  EXPECT_EQ(second->source, DrtCacheSource::loaded);
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
  EXPECT_NE(after_move->source, DrtCacheSource::loaded);
  EXPECT_NE(after_move->path, first->path);

  // A truncated file is rebuilt and replaced, the reason reported.
  fs::resize_file(first->path, fs::file_size(first->path) / 2);
  Result<DrtCacheResult> repaired =
      load_or_build_drt(level.value(), dict(), s.clutter, quick(), dir.str(), record);
  ASSERT_TRUE(repaired.ok()) << repaired.status().to_string();
  EXPECT_NE(repaired->source, DrtCacheSource::loaded);
  EXPECT_FALSE(repaired->rebuilt.empty());
  EXPECT_EQ(bytes_of(repaired->operators), bytes_of(first->operators));
  Result<DrtCacheResult> again = load_or_build_drt(level.value(), dict(), s.clutter, quick(), dir.str());
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->source, DrtCacheSource::loaded);

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
  EXPECT_NE(misfit->source, DrtCacheSource::loaded);
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
  EXPECT_EQ(plain->source, DrtCacheSource::built);
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

// ---- The build state file (drt_state_io.h) ----

// A box as a mesh of 12 triangles, 4 x 4 texels a face.
ClutterObject mesh_box(const glm::dvec3& center, const glm::dvec3& albedo) {
  ClutterBox box;
  box.center = center;
  box.half_extent = glm::dvec3(0.06, 0.1, 0.06);
  Result<ClutterObject> o = make_mesh_clutter(test::box_mesh(box, 4, 18), 0, albedo, 18, "test mesh");
  EXPECT_TRUE(o.ok()) << o.status().to_string();
  return o.ok() ? std::move(o).value() : ClutterObject{};
}

// The two boxes (at res 8) and a box-shaped mesh between them.
std::vector<ClutterObject> boxes_and_a_mesh() {
  std::vector<ClutterObject> objects = two_boxes_in_a_row().clutter;
  for (ClutterObject& o : objects) o.res = 8;
  objects.push_back(mesh_box(glm::dvec3(0.5, 0.1, 0.22), glm::dvec3(0.4, 0.7, 0.4)));
  return objects;
}

// Every setting a rebuild supports: the gather (the default), the paper's operators with the
// vector and probe passes and dropped rows, a lighting prior for c.
TEST(DrtState, WrittenAndReadBackItRebuildsAsAFullBuild) {
  const ClutterScene s = two_boxes_in_a_row();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings gather = quick();
  gather.rays = 32;
  DrtBuildSettings paper = paper_operators(gather);
  paper.vector = paper.probes = true;
  paper.drop_tolerance = 0.01;
  DrtBuildSettings prior = gather;
  prior.clutter_prior_modes = 3;
  prior.sample_gather = true;
  for (const auto& [name, settings] : {std::pair<const char*, DrtBuildSettings>{"gather", gather},
                                       {"paper, vector, probes", paper},
                                       {"prior", prior}}) {
    SCOPED_TRACE(name);
    std::vector<ClutterObject> objects = boxes_and_a_mesh();
    const DrtBuilder builder(level, dict(), settings);
    DrtBuildState built;
    DrtOperators drt = builder.build(objects, nullptr, &built).value();
    // One encoding: read back, it writes the same bytes; the key travels with it.
    const std::vector<std::byte> bytes = state_bytes(built, 0x0123456789abcdefull);
    Result<LoadedDrtBuildState> loaded = parse_drt_build_state(bytes, "state");
    ASSERT_TRUE(loaded.ok()) << loaded.status().to_string();
    EXPECT_EQ(loaded->scene_key, 0x0123456789abcdefull);
    EXPECT_EQ(state_bytes(loaded->state, loaded->scene_key), bytes);
    ASSERT_EQ(loaded->state.objects().size(), objects.size());
    // The mesh comes back as the object the build saw (its atlas made again).
    EXPECT_EQ(clutter_texel_count(loaded->state.objects()[2]), clutter_texel_count(objects[2]));
    // Move a box, then the mesh (a new mesh): each rebuilt on the loaded state equals a full build.
    objects[1].box.center += glm::dvec3(-0.05, 0.0, 0.08);
    ASSERT_TRUE(builder.rebuild_object(objects, 1, drt, loaded->state).ok());
    expect_same_operators(drt, builder.build(objects).value(), std::string(name) + ", box moved");
    objects[2] = mesh_box(glm::dvec3(0.55, 0.1, 0.8), objects[2].albedo);
    ASSERT_TRUE(builder.rebuild_object(objects, 2, drt, loaded->state).ok());
    expect_same_operators(drt, builder.build(objects).value(), std::string(name) + ", mesh moved");
  }
}

// Where the first traced scene sample with a dUb row sits in a state file of box objects
// (drt_state_io.h's layout): the offsets of its row's object index, of the row's block count
// and of its first value.
struct FirstRow {
  std::size_t sample = 0, object_at = 0, blocks_at = 0, value_at = 0;
};
FirstRow first_row(std::span<const std::byte> b, std::size_t objects) {
  using test::get_u32;
  std::size_t at = kDrtStateFileHeaderBytes + 40 + 160 * objects;  // settings, box objects
  const std::size_t samples = get_u32(b, at);
  at += 4;
  for (std::size_t s = 0; s < samples; ++s) {
    const std::size_t rows = get_u32(b, at + 8);
    at += 12;
    for (std::size_t r = 0; r < rows; ++r) {
      const std::size_t object_at = at, blocks = get_u32(b, at + 4);
      if (blocks > 0) return {s, object_at, at + 4, at + 12};
      at += 8;
      at += 4 + 8 * std::size_t(get_u32(b, at));   // dUc
      at += 4 + 8 * std::size_t(get_u32(b, at));   // sample weights
      at += 4 + 12 * std::size_t(get_u32(b, at));  // texel weights
    }
  }
  ADD_FAILURE() << "no traced sample with a dUb row";
  return {};
}

TEST(DrtCache, MovedObjectIsRebuiltAloneAndLoadedOnTheNextStart) {
  ClutterScene s = maze_block_four_pillars();
  const Level level = build_level(s.description, dict()).value();
  for (ClutterObject& o : s.clutter) o.res = 8;
  DrtBuildSettings settings = quick();
  settings.rays = 32;
  TempDir dir;
  std::vector<std::string> log;
  const auto record = [&](const std::string& line) { log.push_back(line); };
  Result<DrtCacheResult> first = load_or_build_drt(level, dict(), s.clutter, settings, dir.str(), record);
  ASSERT_TRUE(first.ok()) << first.status().to_string();
  EXPECT_EQ(first->source, DrtCacheSource::built);
  ASSERT_TRUE(fs::exists(first->state_path)) << first->state_path;
  EXPECT_EQ(fs::path(first->state_path).filename().string(),
            drt_state_file_name(drt_scene_key(level, dict().settings, s.clutter.size(), settings).value()));

  // Pillar 2 moved: it alone is re-traced, from the state and the operators of the first start.
  std::vector<ClutterObject> moved = s.clutter;
  moved[2].box.center += glm::dvec3(0.08, 0.0, -0.05);
  log.clear();
  Result<DrtCacheResult> second = load_or_build_drt(level, dict(), moved, settings, dir.str(), record);
  ASSERT_TRUE(second.ok()) << second.status().to_string();
  EXPECT_EQ(second->source, DrtCacheSource::incremental) << second->state_unused;
  EXPECT_EQ(second->retraced, std::vector<std::size_t>{2});
  EXPECT_NE(second->path, first->path);
  ASSERT_FALSE(log.empty());
  EXPECT_EQ(
      log[0].rfind(
          "rebuilt DRT operators incrementally from " + second->state_path + ": re-traced object 2 of 4", 0),
      0u)
      << log[0];
  const DrtOperators full = DrtBuilder(level, dict(), settings).build(moved).value();
  expect_same_operators(second->operators, full, "one pillar moved");
  // The state now holds the moved pillar.
  Result<LoadedDrtBuildState> state = load_drt_build_state(second->state_path);
  ASSERT_TRUE(state.ok()) << state.status().to_string();
  EXPECT_EQ(state->state.objects()[2].box.center, moved[2].box.center);

  // The next start loads, nothing is built.
  Result<DrtCacheResult> third = load_or_build_drt(level, dict(), moved, settings, dir.str());
  ASSERT_TRUE(third.ok());
  EXPECT_EQ(third->source, DrtCacheSource::loaded);
  EXPECT_EQ(bytes_of(third->operators), bytes_of(full));

  // Two more pillars moved and a third recoloured: one at a time, in order.
  std::vector<ClutterObject> again = moved;
  again[0].box.center.x -= 0.05;
  again[3].albedo = glm::dvec3(0.3);
  Result<DrtCacheResult> fourth = load_or_build_drt(level, dict(), again, settings, dir.str());
  ASSERT_TRUE(fourth.ok());
  EXPECT_EQ(fourth->source, DrtCacheSource::incremental) << fourth->state_unused;
  EXPECT_EQ(fourth->retraced, (std::vector<std::size_t>{0, 3}));
  expect_same_operators(fourth->operators, DrtBuilder(level, dict(), settings).build(again).value(),
                        "two pillars changed");
  // More than half changed: a full build, the reason given.
  for (ClutterObject& o : again) o.box.center.z += 0.02;
  Result<DrtCacheResult> fifth = load_or_build_drt(level, dict(), again, settings, dir.str());
  ASSERT_TRUE(fifth.ok());
  EXPECT_EQ(fifth->source, DrtCacheSource::built);
  EXPECT_NE(fifth->state_unused.find("4 of 4 objects changed"), std::string::npos) << fifth->state_unused;
  // Other settings: another scene, another state; none yet, so built.
  DrtBuildSettings other = settings;
  other.seed += 1;
  Result<DrtCacheResult> sixth = load_or_build_drt(level, dict(), moved, other, dir.str());
  ASSERT_TRUE(sixth.ok());
  EXPECT_EQ(sixth->source, DrtCacheSource::built);
  EXPECT_NE(sixth->state_path, first->state_path);
  EXPECT_TRUE(sixth->state_unused.empty());
}

TEST(DrtState, DamagedFilesAreRefusedNamingThePartAndReplaced) {
  const ClutterScene s = two_boxes_in_a_row();
  const Level level = build_level(s.description, dict()).value();
  TempDir dir;
  Result<DrtCacheResult> first = load_or_build_drt(level, dict(), s.clutter, quick(), dir.str());
  ASSERT_TRUE(first.ok()) << first.status().to_string();
  const std::string path = first->state_path;
  Result<std::vector<std::byte>> read = read_file(path, kMaxDrtStateFileBytes);
  ASSERT_TRUE(read.ok()) << read.status().to_string();
  const std::vector<std::byte> good = read.value();
  ASSERT_TRUE(parse_drt_build_state(good, path).ok());
  const FirstRow row = first_row(good, s.clutter.size());
  const std::string at = "scene pass sample " + std::to_string(row.sample);
  struct Damage {
    const char* what;
    std::vector<std::byte> bytes;
    ErrorCode code;
    std::string names;
  };
  std::vector<Damage> damages;
  auto resealed = [&](auto&& edit) {
    std::vector<std::byte> b = good;
    edit(b);
    test::put_sealed_body_size(b);
    test::reseal_sealed_file(b);
    return b;
  };
  damages.push_back({"truncated", std::vector<std::byte>(good.begin(), good.begin() + good.size() / 2),
                     ErrorCode::format_error, "truncated"});
  std::vector<std::byte> flipped = good;
  flipped[good.size() - 5] ^= std::byte(0x10);
  damages.push_back({"a flipped bit", flipped, ErrorCode::checksum_mismatch, "body checksum"});
  damages.push_back({"another version",
                     resealed([](auto& b) { test::put_u32(b, 8, kDrtStateFileVersion + 1); }),
                     ErrorCode::version_mismatch, "format version"});
  damages.push_back({"a huge object count", resealed([](auto& b) { test::put_u32(b, 28, 0xFFFFFFF0u); }),
                     ErrorCode::format_error, "objects"});
  damages.push_back({"a huge block count",
                     resealed([&](auto& b) { test::put_u32(b, row.blocks_at, 0x7FFFFFFFu); }),
                     ErrorCode::format_error, at + " object"});
  damages.push_back({"an object out of range",
                     resealed([&](auto& b) { test::put_u32(b, row.object_at, 77); }), ErrorCode::format_error,
                     at + ": rows of object 77, of 2 objects"});
  damages.push_back({"a block out of range",
                     resealed([&](auto& b) { test::put_u32(b, row.value_at - 4, 9); }),
                     ErrorCode::format_error, "block 9, of 1 level blocks"});
  damages.push_back({"NaN in a row",
                     resealed([&](auto& b) { test::put_u64(b, row.value_at, 0x7FF8000000000000ull); }),
                     ErrorCode::non_finite, "dUb has NaN or Inf"});
  damages.push_back({"trailing bytes", resealed([](auto& b) { b.insert(b.end(), 4, std::byte(0)); }),
                     ErrorCode::format_error, "trailing bytes"});
  for (const Damage& d : damages) {
    SCOPED_TRACE(d.what);
    Result<LoadedDrtBuildState> r = parse_drt_build_state(d.bytes, path);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), d.code) << r.status().to_string();
    EXPECT_EQ(r.status().message().rfind(path + ": ", 0), 0u) << r.status().to_string();
    EXPECT_NE(r.status().message().find(d.names), std::string::npos) << r.status().to_string();
  }
  // In the cache: refused, a full build instead (its operators), and the state replaced.
  std::vector<ClutterObject> moved = s.clutter;
  moved[0].box.center.z += 0.05;
  const DrtOperators full = DrtBuilder(level, dict(), quick()).build(moved).value();
  for (const Damage& d : {damages[0], damages[5]}) {
    SCOPED_TRACE(d.what);
    ASSERT_TRUE(write_file_atomic(path, d.bytes).ok());
    Result<DrtCacheResult> r = load_or_build_drt(level, dict(), moved, quick(), dir.str());
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    EXPECT_EQ(r->source, DrtCacheSource::built);
    EXPECT_NE(r->state_unused.find(path + ": "), std::string::npos) << r->state_unused;
    EXPECT_EQ(bytes_of(r->operators), bytes_of(full));
    Result<LoadedDrtBuildState> replaced = load_drt_build_state(path);
    ASSERT_TRUE(replaced.ok()) << replaced.status().to_string();
    EXPECT_EQ(replaced->state.objects()[0].box.center, moved[0].box.center);
    fs::remove(r->path);  // so that the next damage is met again
  }
  // A state under another scene's name (a copied file): refused by its key.
  {
    const std::vector<std::byte> copied =
        resealed([](auto& b) { test::put_u32(b, 36, test::get_u32(b, 36) ^ 1u); });
    ASSERT_TRUE(write_file_atomic(path, copied).ok());
    Result<DrtCacheResult> r = load_or_build_drt(level, dict(), moved, quick(), dir.str());
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r->source, DrtCacheSource::built);
    EXPECT_NE(r->state_unused.find("made for another scene"), std::string::npos) << r->state_unused;
  }
  // rebuild_object refuses a state of other settings, naming the setting.
  Result<LoadedDrtBuildState> loaded = parse_drt_build_state(good, path);
  ASSERT_TRUE(loaded.ok());
  DrtBuildSettings seeded = quick();
  seeded.seed += 1;
  DrtOperators drt = first->operators;
  const Status st = DrtBuilder(level, dict(), seeded).rebuild_object(moved, 0, drt, loaded->state);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("another seed"), std::string::npos) << st.to_string();
}

// Writes the fuzzer's seeds (tests/fuzz/corpus/drt_state) again after a format change: tiny
// states of the tiny res-2, kb-2 corpus dictionary in a one-block room, a box at res 1 with 4
// rays, and a box and a box mesh with the paper's operators and the vector and probe passes.
//   build-tests/bin/test_drt --gtest_also_run_disabled_tests
//   --gtest_filter='DrtState.DISABLED_WriteFuzzSeeds'
TEST(DrtState, DISABLED_WriteFuzzSeeds) {
  Result<Dictionary> tiny = load_dictionary(MODRT_CORPUS_DIR "/dictionary/tiny_interfaces.modrt");
  ASSERT_TRUE(tiny.ok()) << tiny.status().to_string();
  const ClutterScene s = box_room_two_boxes();
  Result<Level> level = build_level(s.description, tiny.value());
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  ClutterObject box = s.clutter[0];
  box.res = 1;
  Result<ClutterObject> mesh =
      make_mesh_clutter(test::box_mesh(s.clutter[1].box, 1, 9), 0, s.clutter[1].albedo, 9, "mesh");
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  DrtBuildSettings plain;
  plain.rays = 4;
  DrtBuildSettings passes = paper_operators(plain);
  passes.vector = passes.probes = true;
  const std::string dir = MODRT_CORPUS_DIR "/drt_state/";
  for (const auto& [name, settings, objects] :
       {std::tuple<const char*, DrtBuildSettings, std::vector<ClutterObject>>{"one_box", plain, {box}},
        {"box_and_mesh_vector_probes", passes, {box, mesh.value()}}}) {
    DrtBuildState state;
    Result<DrtOperators> drt =
        DrtBuilder(level.value(), tiny.value(), settings).build(objects, nullptr, &state);
    ASSERT_TRUE(drt.ok()) << drt.status().to_string();
    ASSERT_TRUE(save_drt_build_state(dir + name + ".modrtdrtstate", state, 1).ok());
  }
}

// The fuzzer's seeds (tests/fuzz/corpus/drt_state) are valid files: each parses and writes back
// byte for byte.
TEST(DrtState, FuzzSeedsAreValidFiles) {
  for (const char* name : {"one_box.modrtdrtstate", "box_and_mesh_vector_probes.modrtdrtstate"}) {
    const std::string path = std::string(MODRT_CORPUS_DIR) + "/drt_state/" + name;
    Result<std::vector<std::byte>> bytes = read_file(path, kMaxDrtStateFileBytes);
    ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
    Result<LoadedDrtBuildState> state = parse_drt_build_state(bytes.value(), path);
    ASSERT_TRUE(state.ok()) << state.status().to_string();
    EXPECT_EQ(state_bytes(state->state, state->scene_key), bytes.value()) << name;
  }
}

}  // namespace
}  // namespace modrt::precompute::drt_test
