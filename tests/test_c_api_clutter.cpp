// SPDX-License-Identifier: MIT
// DRT clutter through the C API (modrt_clutter, modrt_context_set_clutter*, since 0.3): a
// .modrtdrt image loaded from memory and from a file; a CPU context against the C++ CPU
// backend with the same operators (bit-identical: the same backend behind the same frame
// pipeline), with and without bounces; a GLES context against the CPU one (relative L2 1e-4,
// float32 targets, as test_backend_conformance); the texels' geometry against core's
// clutter_texel_geometry (float rounding); and bad input refused naming the argument, with
// nothing changed.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <numeric>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "c_api_test_support.h"
#include "clutter_meshes.h"
#include "drt_scenes.h"
#include "gl_test_context.h"
#include "modrt/cpu/cpu_backend.h"
#include "modrt/dictionary_io.h"
#include "modrt/drt_io.h"
#include "modrt/file_io.h"
#include "modrt/frame_pipeline.h"
#include "modrt/level_geometry.h"
#include "modrt/level_io.h"
#include "modrt/modrt.h"
#include "modrt/modrt.hpp"
#include "modrt/platform/gl_context.h"
#include "modrt/precompute/clutter_mesh.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/precompute/level_build.h"
#include "test_support.h"

namespace modrt {
namespace {

using test::expect_error;
using test::rel_l2;

const Dictionary& dict() { return test::small_test_dictionary(); }

struct Scene {
  test::ClutterScene scene;
  Level level;
  DrtOperators drt;
  std::vector<std::byte> drt_file, level_file, dict_file;
  std::vector<float> ld, clutter_ld, clutter_direct, clutter_albedo;
};

// Four pillars in the middle block of a corridor (their shadows fall through the openings),
// with vector and probe deltas; ld a fixed pseudo-random signal. The paper's operators (Cb,
// Cc: the converged solve takes them), or with `gather` the real-radiance gather (the build's
// default; no converged solve).
Scene make_pillars(bool gather) {
  {
    Scene t;
    t.scene = test::maze_block_four_pillars();
    t.level = precompute::build_level(t.scene.description, dict()).value();
    precompute::DrtBuildSettings settings;
    settings.rays = 64;
    settings.vector = settings.probes = true;
    settings.gather = gather;
    t.drt = precompute::DrtBuilder(t.level, dict(), settings).build(t.scene.clutter).value();
    t.drt_file = serialize_drt(t.drt).value();
    t.level_file = serialize_level(t.level).value();
    t.dict_file = serialize_dictionary(dict()).value();
    const std::size_t texels = drt_buffer_sizes(t.drt).clutter_texels;
    for (std::size_t i = 0; i < 3 * std::size_t(t.level.sample_count); ++i)
      t.ld.push_back(float((i * 7919) % 101) / 100.0f);
    for (std::size_t i = 0; i < 3 * texels; ++i) {
      t.clutter_ld.push_back(float((i * 104729) % 97) / 90.0f);
      t.clutter_direct.push_back(float((i * 31) % 13) / 20.0f);
      t.clutter_albedo.push_back(0.3f + 0.5f * float(i % 3) / 2.0f);
    }
    return t;
  }
}
const Scene& pillars(bool gather = false) {
  static const Scene paper = make_pillars(false);
  if (!gather) return paper;
  static const Scene with_gather = make_pillars(true);
  return with_gather;
}

// The handles of a context on the pillars' level.
struct Handles {
  modrt_dictionary* d = nullptr;
  modrt_level* l = nullptr;
  modrt_clutter* clutter = nullptr;
  explicit Handles(bool gather = false) {
    const Scene& s = pillars(gather);
    EXPECT_EQ(modrt_dictionary_load_memory(s.dict_file.data(), s.dict_file.size(), "dict", nullptr, &d),
              MODRT_OK);
    EXPECT_EQ(modrt_level_load_memory(s.level_file.data(), s.level_file.size(), "pillars", nullptr, &l),
              MODRT_OK);
    EXPECT_EQ(modrt_clutter_load_memory(s.drt_file.data(), s.drt_file.size(), "pillars.modrtdrt", nullptr,
                                        &clutter),
              MODRT_OK)
        << modrt_last_error();
  }
  ~Handles() {
    modrt_clutter_destroy(clutter);
    modrt_level_destroy(l);
    modrt_dictionary_destroy(d);
  }
  modrt_context* context(modrt_backend backend, std::uint32_t bounces) const {
    modrt_context_options o;
    modrt_context_options_init(&o);
    o.backend = backend;
    o.bounces = bounces;
    modrt_context* c = nullptr;
    EXPECT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
    return c;
  }
};

struct Results {
  std::vector<float> lightmap, clutter_lightmap;
};

// One frame of the pillars with their clutter light (and albedo with bounces) through the C API.
Results c_api_frame(modrt_context* c, const Handles& h, bool with_albedo, bool gather = false) {
  const Scene& s = pillars(gather);
  EXPECT_EQ(modrt_context_set_clutter(c, h.clutter), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(
      modrt_context_set_clutter_light(c, s.clutter_ld.data(), s.clutter_direct.data(), s.clutter_ld.size()),
      MODRT_OK)
      << modrt_last_error();
  if (with_albedo) {
    EXPECT_EQ(modrt_context_set_clutter_albedo(c, s.clutter_albedo.data(), s.clutter_albedo.size()), MODRT_OK)
        << modrt_last_error();
  }
  EXPECT_EQ(modrt_context_set_ld(c, s.ld.data(), s.ld.size()), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  Results r;
  r.lightmap.resize(s.ld.size());
  r.clutter_lightmap.resize(s.clutter_ld.size());
  EXPECT_EQ(modrt_context_read_lightmap(c, r.lightmap.data(), r.lightmap.size()), MODRT_OK)
      << modrt_last_error();
  EXPECT_EQ(modrt_context_read_clutter_lightmap(c, r.clutter_lightmap.data(), r.clutter_lightmap.size()),
            MODRT_OK)
      << modrt_last_error();
  return r;
}

// The same frame on the C++ CPU backend the context uses: the level's albedo, the same clutter.
Results cpp_frame(std::uint32_t bounces, bool with_albedo, bool gather = false) {
  const Scene& s = pillars(gather);
  cpu::CpuRuntimeOptions o;
  o.skip.enabled = true;  // as options.skip_unchanged's default
  std::unique_ptr<Backend> be = cpu::create_cpu_backend(s.level, dict(), o).value();
  FrameOptions fo;
  fo.bounces = bounces;
  FramePipeline p = FramePipeline::create(*be, fo).value();
  EXPECT_TRUE(p.set_albedo(level_sample_albedo(s.level)).ok());
  EXPECT_TRUE(p.set_clutter(&s.drt).ok());
  EXPECT_TRUE(p.set_clutter_light(s.clutter_ld, s.clutter_direct).ok());
  if (with_albedo) {
    EXPECT_TRUE(p.set_clutter_albedo(s.clutter_albedo).ok());
  }
  EXPECT_TRUE(p.run(s.ld).ok());
  Results r;
  r.lightmap.resize(s.ld.size());
  r.clutter_lightmap.resize(s.clutter_ld.size());
  EXPECT_TRUE(be->read_lightmap(r.lightmap).ok());
  EXPECT_TRUE(be->read_clutter_lightmap(r.clutter_lightmap).ok());
  return r;
}

void check_cpu_context_is_the_cpp_backend(bool gather);

// One bounce, two feedback steps and the converged solve (b and the clutter's c together; with
// the gather's operators the level's solve and then kGatherConvergedSteps feedback steps).
TEST(CApiClutter, CpuContextIsTheCppBackendBitForBit) {
  for (const bool gather : {false, true}) {
    SCOPED_TRACE(gather ? "gather" : "paper operators");
    check_cpu_context_is_the_cpp_backend(gather);
  }
}

void check_cpu_context_is_the_cpp_backend(bool gather) {
  Handles h(gather);
  for (std::uint32_t bounces : {0u, 2u, std::uint32_t(MODRT_BOUNCES_CONVERGED)}) {
    modrt_context* c = h.context(MODRT_BACKEND_CPU, bounces);
    const Results got = c_api_frame(c, h, bounces > 0, gather);
    const Results ref = cpp_frame(bounces, bounces > 0, gather);
    EXPECT_EQ(got.lightmap, ref.lightmap) << bounces << " bounces";
    EXPECT_EQ(got.clutter_lightmap, ref.clutter_lightmap) << bounces << " bounces";
    if (bounces == MODRT_BOUNCES_CONVERGED) {
      modrt_solve_stats st = modrt::rt::sized<modrt_solve_stats>();
      ASSERT_EQ(modrt_context_get_solve_stats(c, &st), MODRT_OK);
      EXPECT_EQ(st.solves, 1u);
      EXPECT_EQ(st.fallback_updates, 0u);
      EXPECT_EQ(st.converged, 1u) << "the converged solve ran with the clutter";
    }
    // The clutter changes the walls: without it the lightmap differs.
    ASSERT_EQ(modrt_context_set_clutter(c, nullptr), MODRT_OK);
    ASSERT_EQ(modrt_context_update(c), MODRT_OK);
    std::vector<float> bare(got.lightmap.size());
    ASSERT_EQ(modrt_context_read_lightmap(c, bare.data(), bare.size()), MODRT_OK);
    EXPECT_GT(rel_l2(bare, got.lightmap), 1e-3);
    expect_error(modrt_context_read_clutter_lightmap(c, bare.data(), got.clutter_lightmap.size()),
                 MODRT_ERROR_INVALID_ARGUMENT, {"modrt_context_read_clutter_lightmap", "no clutter"});
    modrt_context_destroy(c);
  }
}

// The C++ wrapper (modrt.hpp): the same frame as the C calls.
TEST(CApiClutter, CppWrapper) {
  const Scene& s = pillars();
  Handles h;
  modrt_context* c = h.context(MODRT_BACKEND_CPU, MODRT_BOUNCES_CONVERGED);  // default_options' bounces
  const Results ref = c_api_frame(c, h, false);
  modrt_context_destroy(c);
  rt::Dictionary dict;
  ASSERT_FALSE(rt::Dictionary::load_memory(s.dict_file.data(), s.dict_file.size(), "dict", dict));
  rt::Level level;
  ASSERT_FALSE(rt::Level::load_memory(s.level_file.data(), s.level_file.size(), "pillars", level));
  rt::Clutter clutter;
  ASSERT_FALSE(rt::Clutter::load_memory(s.drt_file.data(), s.drt_file.size(), "pillars", clutter));
  EXPECT_EQ(clutter.info().texel_count * 3, s.clutter_ld.size());
  rt::Context ctx;
  ASSERT_FALSE(rt::Context::create(dict, level, rt::default_options(), ctx));
  ASSERT_FALSE(ctx.set_clutter(clutter));
  ASSERT_FALSE(ctx.set_clutter_light(s.clutter_ld.data(), s.clutter_direct.data(), s.clutter_ld.size()));
  ASSERT_FALSE(ctx.set_ld(s.ld.data(), s.ld.size()));
  ASSERT_FALSE(ctx.update());
  std::vector<float> clutter_lightmap(ref.clutter_lightmap.size());
  ASSERT_FALSE(ctx.read_clutter_lightmap(clutter_lightmap.data(), clutter_lightmap.size()));
  EXPECT_EQ(clutter_lightmap, ref.clutter_lightmap);
  const rt::Error e = ctx.set_clutter_light(s.clutter_ld.data(), nullptr, 3);  // wrong count
  EXPECT_TRUE(e);
  EXPECT_EQ(e.code, MODRT_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(e.message.find("count is 3"), std::string::npos) << e.message;
  ASSERT_FALSE(ctx.set_clutter(rt::Clutter()));  // removed
}

// The file a tool writes loads like the memory image, and the texels are where core puts them.
TEST(CApiClutter, FileInfoAndTexelGeometry) {
  const Scene& s = pillars();
  const std::filesystem::path dir = std::filesystem::path(MODRT_TEST_CACHE_DIR) / "c_api";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "pillars.modrtdrt").string();
  ASSERT_TRUE(save_drt(path, s.drt).ok());
  modrt_clutter* c = nullptr;
  ASSERT_EQ(modrt_clutter_load_file(path.c_str(), nullptr, &c), MODRT_OK) << modrt_last_error();
  modrt_clutter_info info = rt::sized<modrt_clutter_info>();
  ASSERT_EQ(modrt_clutter_get_info(c, &info), MODRT_OK);
  EXPECT_EQ(info.object_count, s.scene.clutter.size());
  EXPECT_EQ(info.texel_count, drt_buffer_sizes(s.drt).clutter_texels);
  EXPECT_EQ(info.has_texel_geometry, 1u);
  std::vector<modrt_clutter_texel> texels(info.texel_count);
  ASSERT_EQ(modrt_clutter_get_texels(c, texels.data(), texels.size()), MODRT_OK) << modrt_last_error();
  std::size_t t = 0;
  for (std::size_t k = 0; k < s.scene.clutter.size(); ++k) {
    const ClutterTexelGeometry g = clutter_texel_geometry(s.scene.clutter[k]);
    for (std::size_t i = 0; i < g.position.size(); ++i, ++t) {
      ASSERT_LT(t, texels.size());
      EXPECT_EQ(texels[t].object, k);
      for (int a = 0; a < 3; ++a) {
        EXPECT_EQ(texels[t].position[a], float(g.position[i][a]));
        EXPECT_EQ(texels[t].normal[a], float(g.normal[i][a]));
      }
    }
  }
  EXPECT_EQ(t, texels.size());
  expect_error(modrt_clutter_get_texels(c, texels.data(), texels.size() - 1), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_clutter_get_texels", "out has " + std::to_string(texels.size() - 1) + " records"});
  modrt_clutter_destroy(c);

  // Operators built without the texels (an app's own builder): no geometry, named.
  DrtOperators bare = s.drt;
  for (DrtObjectOperators& o : bare.objects) o.texel_position.clear(), o.texel_normal.clear();
  const std::vector<std::byte> bytes = serialize_drt(bare).value();
  ASSERT_EQ(modrt_clutter_load_memory(bytes.data(), bytes.size(), "bare", nullptr, &c), MODRT_OK);
  ASSERT_EQ(modrt_clutter_get_info(c, &info), MODRT_OK);
  EXPECT_EQ(info.has_texel_geometry, 0u);
  expect_error(modrt_clutter_get_texels(c, texels.data(), texels.size()), MODRT_ERROR_UNSUPPORTED,
               {"records no texel positions"});
  modrt_clutter_destroy(c);
}

// modrt_clutter_get_texel_cells: each texel's lightmap cell is core's clutter_texel_cells of the
// object the operators were built from, through the file: for boxes (the pillars) the cell's
// centre on its face is the texel's position; for a mesh (a box as 12 triangles with a UV
// atlas, next to a box) the cell is the atlas cell whose texel it is (cell_texel), its face the
// chart. Cells are distinct per object. Bad input and operators without cells are named, with
// nothing written; a version 2 file (no cells) is refused with "rebuild".
TEST(CApiClutter, TexelCellsAreTheObjectsLightmapCells) {
  // Boxes.
  const Scene& s = pillars();
  modrt_clutter* c = nullptr;
  ASSERT_EQ(modrt_clutter_load_memory(s.drt_file.data(), s.drt_file.size(), "pillars", nullptr, &c), MODRT_OK)
      << modrt_last_error();
  modrt_clutter_info info = rt::sized<modrt_clutter_info>();
  ASSERT_EQ(modrt_clutter_get_info(c, &info), MODRT_OK);
  std::vector<modrt_clutter_cell> cells(info.texel_count);
  std::vector<modrt_clutter_texel> texels(info.texel_count);
  ASSERT_EQ(modrt_clutter_get_texel_cells(c, cells.data(), cells.size()), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_clutter_get_texels(c, texels.data(), texels.size()), MODRT_OK) << modrt_last_error();
  std::size_t t = 0;
  for (std::size_t k = 0; k < s.scene.clutter.size(); ++k) {
    const ClutterObject& object = s.scene.clutter[k];
    ASSERT_EQ(object.kind, ClutterKind::box);
    const ClutterTexelCells ref = clutter_texel_cells(object);
    ASSERT_EQ(ref.face.size(), std::size_t(clutter_texel_count(object)));
    std::set<std::array<std::uint32_t, 3>> seen;
    for (std::size_t i = 0; i < ref.face.size(); ++i, ++t) {
      ASSERT_LT(t, cells.size());
      const modrt_clutter_cell& x = cells[t];
      EXPECT_EQ(x.object, k);
      EXPECT_EQ(x.face, std::uint32_t(ref.face[i]));
      EXPECT_EQ(x.u, std::uint32_t(ref.cell[i].x));
      EXPECT_EQ(x.v, std::uint32_t(ref.cell[i].y));
      EXPECT_EQ(x.res, std::uint32_t(object.res));
      seen.insert({x.face, x.u, x.v});
      const glm::dvec3 centre =
          clutter_face_point(object.box, int(x.face), (x.u + 0.5) / x.res, (x.v + 0.5) / x.res);
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(texels[t].position[a], centre[a], 1e-6) << "texel " << t;
    }
    EXPECT_EQ(seen.size(), ref.face.size()) << "two texels in one cell";
  }
  EXPECT_EQ(t, cells.size());
  rt::Clutter wrapped;
  ASSERT_FALSE(rt::Clutter::load_memory(s.drt_file.data(), s.drt_file.size(), "pillars", wrapped));
  std::vector<modrt_clutter_cell> again(cells.size());
  ASSERT_FALSE(wrapped.texel_cells(again.data(), again.size()));
  EXPECT_EQ(std::memcmp(again.data(), cells.data(), cells.size() * sizeof cells[0]), 0);

  // Bad input: named, nothing written.
  std::vector<modrt_clutter_cell> keep(cells.size());
  std::memset(keep.data(), 0xab, keep.size() * sizeof keep[0]);
  std::vector<modrt_clutter_cell> out = keep;
  const auto unchanged = [&] {
    EXPECT_EQ(std::memcmp(out.data(), keep.data(), out.size() * sizeof out[0]), 0);
  };
  expect_error(modrt_clutter_get_texel_cells(nullptr, out.data(), out.size()), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_clutter_get_texel_cells", "clutter is null"});
  expect_error(modrt_clutter_get_texel_cells(c, nullptr, out.size()), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_clutter_get_texel_cells", "out is null"});
  expect_error(modrt_clutter_get_texel_cells(c, out.data(), out.size() - 1), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_clutter_get_texel_cells", "out has " + std::to_string(out.size() - 1) + " records",
                std::to_string(out.size()) + " texels"});
  unchanged();
  modrt_clutter_destroy(c);
  // Operators assembled without cells (an app's own builder): unsupported, named.
  DrtOperators bare = s.drt;
  for (DrtObjectOperators& o : bare.objects) o.texel_cell.clear(), o.cell_res = 0;
  const std::vector<std::byte> bare_file = serialize_drt(bare).value();
  ASSERT_EQ(modrt_clutter_load_memory(bare_file.data(), bare_file.size(), "bare", nullptr, &c), MODRT_OK)
      << modrt_last_error();
  expect_error(modrt_clutter_get_texel_cells(c, out.data(), out.size()), MODRT_ERROR_UNSUPPORTED,
               {"modrt_clutter_get_texel_cells", "record no texel cells", "rebuild"});
  unchanged();
  modrt_clutter_destroy(c);
  // A version 2 file (before the cells): refused at load.
  std::vector<std::byte> v2 = s.drt_file;
  const std::uint32_t two = 2;
  std::memcpy(v2.data() + 8, &two, 4);
  c = nullptr;
  expect_error(modrt_clutter_load_memory(v2.data(), v2.size(), "v2.modrtdrt", nullptr, &c),
               MODRT_ERROR_VERSION_MISMATCH,
               {"v2.modrtdrt", "format version 2", "rebuild the clutter operators"});
  EXPECT_EQ(c, nullptr);
  // Damaged cells behind valid checksums are refused when set on a level (check_drt_operators).
  DrtOperators twice = s.drt;
  twice.objects[0].texel_cell[4] = twice.objects[0].texel_cell[1];  // texel 1 in texel 0's cell
  twice.objects[0].texel_cell[5] = twice.objects[0].texel_cell[2];
  twice.objects[0].texel_cell[3] = twice.objects[0].texel_cell[0];
  Status shared = check_drt_operators(s.level, twice);
  EXPECT_FALSE(shared.ok());
  EXPECT_NE(shared.message().find("DRT object 0: texel_cell: two texels share a cell"), std::string::npos)
      << shared.message();
  DrtOperators outside = s.drt;
  outside.objects[1].texel_cell[1] = outside.objects[1].cell_res;
  shared = check_drt_operators(s.level, outside);
  EXPECT_NE(shared.message().find("DRT object 1: texel_cell of texel 0: cell (" +
                                  std::to_string(outside.objects[1].cell_res)),
            std::string::npos)
      << shared.message();

  // A mesh: the cells of its UV atlas.
  test::ClutterScene room = test::box_room_two_boxes();
  const int n = 4, res = 3 * (n + 2);
  Result<ClutterObject> mesh = precompute::make_mesh_clutter(test::box_mesh(room.clutter[1].box, n, res), 0,
                                                             room.clutter[1].albedo, res, "mesh box");
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  room.clutter[1] = mesh.value();
  room.clutter[0].res = 4;
  const Level level = precompute::build_level(room.description, dict()).value();
  precompute::DrtBuildSettings settings;
  settings.rays = 32;
  const DrtOperators drt = precompute::DrtBuilder(level, dict(), settings).build(room.clutter).value();
  const std::vector<std::byte> file = serialize_drt(drt).value();
  ASSERT_EQ(modrt_clutter_load_memory(file.data(), file.size(), "room", nullptr, &c), MODRT_OK)
      << modrt_last_error();
  info = rt::sized<modrt_clutter_info>();
  ASSERT_EQ(modrt_clutter_get_info(c, &info), MODRT_OK);
  cells.assign(info.texel_count, modrt_clutter_cell{});
  ASSERT_EQ(modrt_clutter_get_texel_cells(c, cells.data(), cells.size()), MODRT_OK) << modrt_last_error();
  const ClutterMeshAtlas& atlas = room.clutter[1].mesh->atlas;
  const std::size_t first = std::size_t(clutter_texel_count(room.clutter[0]));
  ASSERT_EQ(cells.size(), first + atlas.texels.face.size());
  EXPECT_EQ(cells[0].res, 4u);
  EXPECT_EQ(cells[first - 1].object, 0u);
  std::size_t charts_seen = 0;
  for (std::size_t i = 0; i < atlas.texels.face.size(); ++i) {
    const modrt_clutter_cell& x = cells[first + i];
    EXPECT_EQ(x.object, 1u);
    EXPECT_EQ(x.res, std::uint32_t(res));
    EXPECT_EQ(x.face, std::uint32_t(atlas.texels.face[i]));
    ASSERT_LT(x.u, x.res);
    ASSERT_LT(x.v, x.res);
    EXPECT_EQ(atlas.cell_texel[std::size_t(x.v) * std::size_t(res) + x.u], std::int32_t(i)) << "texel " << i;
    charts_seen = std::max(charts_seen, std::size_t(x.face) + 1);
  }
  EXPECT_EQ(charts_seen, std::size_t(kFaceCount));                       // one chart per box face
  EXPECT_GE(atlas.texels.face.size(), std::size_t(kFaceCount * n * n));  // every overlapped cell is a texel
  modrt_clutter_destroy(c);
}

TEST(CApiClutter, BadInputIsNamedAndChangesNothing) {
  const Scene& s = pillars();
  Handles h;
  modrt_context* c = h.context(MODRT_BACKEND_CPU, 0);
  std::vector<float> light = s.clutter_ld;
  expect_error(modrt_context_set_clutter_light(c, light.data(), nullptr, light.size()),
               MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_set_clutter_light", "no clutter (modrt_context_set_clutter)"});
  const Results good = c_api_frame(c, h, false);
  // Wrong count, NaN, negative, null: refused; the next update gives the same frame.
  expect_error(modrt_context_set_clutter_light(c, light.data(), nullptr, light.size() - 3),
               MODRT_ERROR_INVALID_ARGUMENT, {"count is " + std::to_string(light.size() - 3), "3 per texel"});
  light[10] = std::numeric_limits<float>::quiet_NaN();
  const modrt_status nan = modrt_context_set_clutter_light(c, light.data(), nullptr, light.size());
  EXPECT_NE(nan, MODRT_OK);
  EXPECT_NE(std::string(modrt_last_error()).find("clutter_ld"), std::string::npos) << modrt_last_error();
  light[10] = -1.0f;
  EXPECT_NE(modrt_context_set_clutter_light(c, light.data(), nullptr, light.size()), MODRT_OK);
  expect_error(modrt_context_set_clutter_light(c, nullptr, nullptr, light.size()),
               MODRT_ERROR_INVALID_ARGUMENT, {"clutter_ld is null"});
  std::vector<float> albedo = s.clutter_albedo;
  albedo[4] = std::numeric_limits<float>::infinity();
  EXPECT_NE(modrt_context_set_clutter_albedo(c, albedo.data(), albedo.size()), MODRT_OK);
  expect_error(modrt_context_set_clutter_albedo(c, albedo.data(), 5), MODRT_ERROR_INVALID_ARGUMENT,
               {"count is 5", "0: no clutter feedback"});
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  std::vector<float> lightmap(good.lightmap.size()), clutter_lightmap(good.clutter_lightmap.size());
  ASSERT_EQ(modrt_context_read_lightmap(c, lightmap.data(), lightmap.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_read_clutter_lightmap(c, clutter_lightmap.data(), clutter_lightmap.size()),
            MODRT_OK);
  EXPECT_EQ(lightmap, good.lightmap);
  EXPECT_EQ(clutter_lightmap, good.clutter_lightmap);
  expect_error(modrt_context_read_clutter_lightmap(c, clutter_lightmap.data(), 7),
               MODRT_ERROR_INVALID_ARGUMENT, {"out has 7 floats"});
  uint32_t texture = 0;
  expect_error(modrt_context_get_clutter_texture(c, &texture, nullptr, nullptr, nullptr),
               MODRT_ERROR_UNSUPPORTED, {"a CPU context has no GL textures"});

  // Operators of another level: a mismatch naming the problem; the context keeps its clutter.
  const test::ClutterScene other = test::box_room_two_boxes();
  const Level other_level = precompute::build_level(other.description, dict()).value();
  const DrtOperators other_drt = precompute::DrtBuilder(other_level, dict(), {}).build(other.clutter).value();
  const std::vector<std::byte> other_file = serialize_drt(other_drt).value();
  modrt_clutter* wrong = nullptr;
  ASSERT_EQ(modrt_clutter_load_memory(other_file.data(), other_file.size(), "room", nullptr, &wrong),
            MODRT_OK);
  const modrt_status mismatch = modrt_context_set_clutter(c, wrong);
  expect_error(mismatch, MODRT_ERROR_MISMATCH,
               {"modrt_context_set_clutter", "does not fit the context's level"});
  modrt_clutter_destroy(wrong);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  ASSERT_EQ(modrt_context_read_clutter_lightmap(c, clutter_lightmap.data(), clutter_lightmap.size()),
            MODRT_OK);
  EXPECT_EQ(clutter_lightmap, good.clutter_lightmap);
  modrt_context_destroy(c);

  // Damaged and older files.
  std::vector<std::byte> damaged = s.drt_file;
  damaged[damaged.size() / 2] ^= std::byte(0x40);
  modrt_clutter* x = nullptr;
  expect_error(modrt_clutter_load_memory(damaged.data(), damaged.size(), "damaged.modrtdrt", nullptr, &x),
               MODRT_ERROR_CHECKSUM_MISMATCH, {"damaged.modrtdrt"});
  EXPECT_EQ(x, nullptr);
  std::vector<std::byte> old = s.drt_file;
  const std::uint32_t v1 = 1;
  std::memcpy(old.data() + 8, &v1, 4);
  expect_error(modrt_clutter_load_memory(old.data(), old.size(), "old.modrtdrt", nullptr, &x),
               MODRT_ERROR_VERSION_MISMATCH, {"old.modrtdrt", "rebuild the clutter operators"});
  expect_error(modrt_clutter_load_file("/nonexistent/c.modrtdrt", nullptr, &x), MODRT_ERROR_IO,
               {"/nonexistent/c.modrtdrt"});
  expect_error(modrt_clutter_load_memory(nullptr, 10, "n", nullptr, &x), MODRT_ERROR_INVALID_ARGUMENT,
               {"data is null"});
  modrt_clutter_destroy(nullptr);
}

// The GLES context: the same frame within 1e-4 of the CPU context, the clutter atlas texture,
// and every texel at its own place in it.
TEST(CApiClutter, GlesContextMatchesTheCpuContext) {
  MODRT_GL_CONTEXT_OR_SKIP(gl, platform::ContextRequest::egl_surfaceless);
  for (const bool gather : {false, true})
    for (std::uint32_t bounces : {0u, 2u}) {
      SCOPED_TRACE(gather ? "gather" : "paper operators");
      Handles h(gather);
      modrt_context* cpu = h.context(MODRT_BACKEND_CPU, bounces);
      modrt_context* gles = h.context(MODRT_BACKEND_GLES, bounces);
      ASSERT_NE(gles, nullptr);
      const Results a = c_api_frame(cpu, h, bounces > 0, gather),
                    b = c_api_frame(gles, h, bounces > 0, gather);
      EXPECT_LT(rel_l2(b.lightmap, a.lightmap), 1e-4) << bounces << " bounces";
      EXPECT_LT(rel_l2(b.clutter_lightmap, a.clutter_lightmap), 1e-4) << bounces << " bounces";
      uint32_t texture = 0, width = 0, height = 0;
      int format = -1;
      ASSERT_EQ(modrt_context_get_clutter_texture(gles, &texture, &format, &width, &height), MODRT_OK)
          << modrt_last_error();
      EXPECT_NE(texture, 0u);
      EXPECT_GE(format, 0);
      std::vector<uint32_t> xy(2 * a.clutter_lightmap.size() / 3);
      ASSERT_EQ(modrt_context_get_clutter_texel_coords(gles, xy.data(), xy.size()), MODRT_OK)
          << modrt_last_error();
      std::set<std::pair<uint32_t, uint32_t>> seen;
      for (std::size_t t = 0; t < xy.size() / 2; ++t) {
        EXPECT_LT(xy[2 * t], width);
        EXPECT_LT(xy[2 * t + 1], height);
        seen.insert({xy[2 * t], xy[2 * t + 1]});
      }
      EXPECT_EQ(seen.size(), xy.size() / 2);  // one texel per place
      expect_error(modrt_context_get_clutter_texel_coords(cpu, xy.data(), xy.size()), MODRT_ERROR_UNSUPPORTED,
                   {"a CPU context has no clutter atlas texture"});
      modrt_context_destroy(gles);
      modrt_context_destroy(cpu);
    }
}

// A GLES context with clutter solves b and the clutter's c together on the GPU
// (MODRT_BOUNCES_CONVERGED): its lightmap and clutter lightmap equal a CPU context's converged
// frame within the two solves' tolerance (1e-3 of max |b| each), are brighter than the
// fallback's four feedback steps, and no update falls back.
TEST(CApiClutter, ConvergedOnGlesWithClutterSolvesBAndC) {
  MODRT_GL_CONTEXT_OR_SKIP(gl, platform::ContextRequest::egl_surfaceless);
  Handles h;
  modrt_context* converged = h.context(MODRT_BACKEND_GLES, MODRT_BOUNCES_CONVERGED);
  modrt_context* four = h.context(MODRT_BACKEND_GLES, kConvergedFallbackSteps);
  modrt_context* cpu = h.context(MODRT_BACKEND_CPU, MODRT_BOUNCES_CONVERGED);
  ASSERT_TRUE(converged && four && cpu);
  const Results a = c_api_frame(converged, h, true), b = c_api_frame(cpu, h, true);
  const Results steps = c_api_frame(four, h, true);
  const double e = rel_l2(a.lightmap, b.lightmap), ec = rel_l2(a.clutter_lightmap, b.clutter_lightmap);
  EXPECT_LT(e, 3e-3);
  EXPECT_LT(ec, 3e-3);
  const auto sum = [](const std::vector<float>& v) { return std::accumulate(v.begin(), v.end(), 0.0); };
  EXPECT_GT(sum(a.lightmap), sum(steps.lightmap)) << "more bounces than four feedback steps";
  EXPECT_GT(sum(a.clutter_lightmap), sum(steps.clutter_lightmap));
  std::printf(
      "  GLES converged with clutter against the CPU's: lightmap rel L2 %.2e, clutter lightmap %.2e\n", e,
      ec);
  modrt_solve_stats st = modrt::rt::sized<modrt_solve_stats>();
  for (modrt_context* c : {converged, cpu}) {
    ASSERT_EQ(modrt_context_get_solve_stats(c, &st), MODRT_OK) << modrt_last_error();
    EXPECT_EQ(st.fallback_updates, 0u);
    EXPECT_EQ(st.solves, 1u);
  }
  modrt_context_destroy(cpu);
  modrt_context_destroy(four);
  modrt_context_destroy(converged);
}

}  // namespace
}  // namespace modrt
