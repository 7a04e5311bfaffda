// SPDX-License-Identifier: MIT
#include "modrt/precompute/level_build.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <string>
#include <tuple>

#include <Eigen/QR>
#include <glm/geometric.hpp>

#include "modrt/precompute/interfaces.h"
#include "modrt/precompute/linalg.h"
#include "modrt/precompute/sh_operators.h"
#include "modrt/precompute/shaped_interfaces.h"
#include "modrt/precompute/shaped_operators.h"
#include "modrt/sh.h"

namespace modrt::precompute {
namespace {

// Texel (i, j) of canonical face f after `turns` quarter turns: walls map texel for texel;
// floor and ceiling turn in their plane.
void rotate_texel(int f, int i, int j, int res, int turns, int& f_out, int& i_out, int& j_out) {
  f_out = rotate_face(f, turns);
  const glm::dvec3 p = rotate_point(face_point(f, (i + 0.5) / res, (j + 0.5) / res), turns);
  const FaceFrame& frame = face_frame(f_out);
  const glm::dvec3 rel = p - frame.origin;
  i_out = std::clamp(int(std::floor(glm::dot(rel, frame.u_axis) * res)), 0, res - 1);
  j_out = std::clamp(int(std::floor(glm::dot(rel, frame.v_axis) * res)), 0, res - 1);
}

// Sample of `face` in block `b` whose texel contains canonical point p (on that face).
int texel_sample(const SampleLayout& layout, int face, const glm::dvec3& p) {
  const FaceFrame& fr = face_frame(face);
  const glm::dvec3 rel = p - fr.origin;
  const int i = std::clamp(int(std::floor(glm::dot(rel, fr.u_axis) * layout.res)), 0, layout.res - 1);
  const int j = std::clamp(int(std::floor(glm::dot(rel, fr.v_axis) * layout.res)), 0, layout.res - 1);
  return layout.index(face, i, j);
}

// Face whose inward normal is `n` (a unit axis vector).
int face_with_normal(const glm::dvec3& n) {
  for (int f = 0; f < kFaceCount; ++f)
    if (glm::dot(face_frame(f).normal, n) > 0.5) return f;
  return -1;
}

// The padded atlas: one (res + 2)^2 tile per present face; padding texels copy the texel
// that continues the surface across the tile edge: the adjacent face of the same block
// across a crease, the same face of the connected block across an interface, or the
// face's own edge texel where the surface ends (MRT §6.2).
void build_atlas(Level& level) {
  const int res = level.res, tile = res + 2;
  LightmapAtlas& atlas = level.atlas;
  atlas.tile = tile;
  int tiles = 0;
  for (const LevelBlock& b : level.blocks) tiles += face_count(dictionary_shape_mask(b.shape));
  const int cols = std::max(1, int(std::ceil(std::sqrt(double(tiles)))));
  const int rows = (tiles + cols - 1) / cols;
  atlas.width = cols * tile;
  atlas.height = rows * tile;
  atlas.sample_texel.assign(level.sample_count, 0);
  atlas.tile_origin_x.assign(level.blocks.size(), {});
  atlas.tile_origin_y.assign(level.blocks.size(), {});
  int t = 0;
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const LevelBlock& b = level.blocks[bi];
    const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(b.shape), res);
    for (int f = 0; f < kFaceCount; ++f) {
      atlas.tile_origin_x[bi][std::size_t(f)] = atlas.tile_origin_y[bi][std::size_t(f)] = -1;
      if (!face_present(layout.mask, f)) continue;
      const int ox = (t % cols) * tile, oy = (t / cols) * tile;
      ++t;
      atlas.tile_origin_x[bi][std::size_t(f)] = ox;
      atlas.tile_origin_y[bi][std::size_t(f)] = oy;
      for (int j = 0; j < res; ++j)
        for (int i = 0; i < res; ++i)
          atlas.sample_texel[b.sample_offset + std::uint32_t(layout.index(f, i, j))] =
              std::uint32_t((oy + 1 + j) * atlas.width + ox + 1 + i);
    }
  }
  const double d = 0.5 / res;
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const LevelBlock& b = level.blocks[bi];
    const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(b.shape), res);
    for (int f = 0; f < kFaceCount; ++f) {
      if (!face_present(layout.mask, f)) continue;
      const FaceFrame& fr = face_frame(f);
      const int ox = atlas.tile_origin_x[bi][std::size_t(f)], oy = atlas.tile_origin_y[bi][std::size_t(f)];
      for (int pj = -1; pj <= res; ++pj)
        for (int pi = -1; pi <= res; ++pi) {
          const bool out_u = pi < 0 || pi >= res, out_v = pj < 0 || pj >= res;
          if (!out_u && !out_v) continue;
          const std::uint32_t dst = std::uint32_t((oy + 1 + pj) * atlas.width + ox + 1 + pi);
          const int ci = std::clamp(pi, 0, res - 1), cj = std::clamp(pj, 0, res - 1);
          std::uint32_t src_block = std::uint32_t(bi);
          int src_sample = layout.index(f, ci, cj);  // default: clamp to the own edge texel
          if (out_u != out_v) {
            const double u = (pi + 0.5) / res, v = (pj + 0.5) / res;
            const glm::dvec3 edge = face_point(f, std::clamp(u, 0.0, 1.0), std::clamp(v, 0.0, 1.0));
            const glm::dvec3 out_dir =
                out_u ? (pi < 0 ? -fr.u_axis : fr.u_axis) : (pj < 0 ? -fr.v_axis : fr.v_axis);
            const int g = face_with_normal(-out_dir);
            if (face_present(layout.mask, g)) {
              src_sample = texel_sample(layout, g, edge + d * fr.normal);  // fold across the crease
            } else if (const int nb = b.neighbour[std::size_t(g)]; nb >= 0) {
              const LevelBlock& c = level.blocks[std::size_t(nb)];
              const glm::dvec3 world = glm::dvec3(b.cell) + rotate_point(edge + d * out_dir, b.quarter_turns);
              const glm::dvec3 local = rotate_point(world - glm::dvec3(c.cell), -c.quarter_turns);
              const int fc = rotate_face(rotate_face(f, b.quarter_turns), -c.quarter_turns);
              const SampleLayout cl = SampleLayout::make(dictionary_shape_mask(c.shape), res);
              if (face_present(cl.mask, fc)) {
                src_block = std::uint32_t(nb);
                src_sample = texel_sample(cl, fc, local);
              }
            }
          }
          const std::uint32_t src =
              atlas.sample_texel[level.blocks[src_block].sample_offset + std::uint32_t(src_sample)];
          atlas.padding.push_back({dst, src});
        }
    }
  }
}

// 9x9 matrix D with coefficients of f(R^-1 w) = D * coefficients of f(w), R = `turns`
// quarter turns about +Y; solved exactly (band-limited) by least squares on 64 directions.
MatrixXd sh9_quarter_turn_matrix(int turns) {
  constexpr int kDirections = 64;
  MatrixXd A(kDirections, 9), B(kDirections, 9);
  for (int n = 0; n < kDirections; ++n) {
    const double z = 1.0 - 2.0 * (n + 0.5) / kDirections, phi = 2.399963229728653 * n;  // golden angle
    const double rr = std::sqrt(std::max(0.0, 1.0 - z * z));
    const glm::dvec3 w(rr * std::cos(phi), rr * std::sin(phi), z);
    double y[9], yr[9];
    sh9_eval(w, y);
    sh9_eval(rotate_direction(w, -turns), yr);
    for (int i = 0; i < 9; ++i) {
      A(n, i) = y[i];
      B(n, i) = yr[i];
    }
  }
  return A.colPivHouseholderQr().solve(B);  // column j: g_j = y_j o R^-1 in the y_i basis
}

// Urvol (canonical entry -Z) turned so light enters through side face `face`.
Matrix turned_probe_response(const Matrix& Urvol, int grid, int face) {
  const int turns = turns_to_face(face);
  const MatrixXd D = sh9_quarter_turn_matrix(turns);
  const MatrixXd U = to_eigen(Urvol);
  MatrixXd out = MatrixXd::Zero(U.rows(), U.cols());
  const int probes = grid * grid * grid;
  for (int p = 0; p < probes; ++p) {
    const glm::dvec3 q = rotate_point(probe_position(p, grid), turns);
    const int ix = std::clamp(int(std::floor(q.x * grid)), 0, grid - 1);
    const int iy = std::clamp(int(std::floor(q.y * grid)), 0, grid - 1);
    const int iz = std::clamp(int(std::floor(q.z * grid)), 0, grid - 1);
    const int p2 = (iz * grid + iy) * grid + ix;
    out.middleRows(9 * Eigen::Index(p2), 9) = D * U.middleRows(9 * Eigen::Index(p), 9);
  }
  return to_float(out);
}

// Ur_vec (canonical entry -Z) turned so light enters through side face `face`. Rows keep
// the dead end's sample order (a slot's ur_row_to_sample places them); the OHLSH linear
// coefficients of each dead-end face are re-expressed in the frame of the face it lands on:
// the gradient g = a3 u' + a1 v' (sh.h: y3 ~ x = u, y1 ~ y = v) turns with the block.
Matrix turned_vector_response(const Matrix& Ur_vec, int res, int face) {
  const int turns = turns_to_face(face);
  const SampleLayout dead_end = SampleLayout::make(dictionary_shape_mask(1), res);
  Matrix out = Ur_vec;
  for (int s = 0; s < dead_end.sample_count(); ++s) {
    const int f = dead_end.face_of(s);
    const FaceFrame& from = face_frame(f);
    const FaceFrame& to = face_frame(rotate_face(f, turns));
    const glm::dvec3 u = rotate_direction(from.u_axis, turns), v = rotate_direction(from.v_axis, turns);
    const double uu = glm::dot(u, to.u_axis), vu = glm::dot(v, to.u_axis);
    const double uv = glm::dot(u, to.v_axis), vv = glm::dot(v, to.v_axis);
    for (std::uint32_t k = 0; k < Ur_vec.cols; ++k) {
      const double a1 = Ur_vec(4 * std::uint32_t(s) + 1, k), a3 = Ur_vec(4 * std::uint32_t(s) + 3, k);
      out(4 * std::uint32_t(s) + 3, k) = float(uu * a3 + vu * a1);
      out(4 * std::uint32_t(s) + 1, k) = float(uv * a3 + vv * a1);
    }
  }
  return out;
}

// MRT §8: every block whose quantised proportions are not a cube's gets the operators of
// its box, one bake per distinct (shape, proportions), shared through the cache. Blocks
// connected to another keep the cube's: their interfaces (R, Trlf_r, Ur) are still the unit
// cube's, and shaped blocks on cube interfaces measured worse in multi-bounce (two 1 x 1 x 3
// blocks as a corridor: converged rel L2 1.11 against the cube operators' 0.70,
// docs/proportions.md).
// Assigns shaped operator sets to blocks whose proportions are not a cube's and, with an
// interface basis, traces the interfaces of every set (returned by set index; empty when
// none was traced) and puts their Rb->rlf into the level's sets.
Result<std::vector<ShapedInterfaces>> assign_shaped_operators(Level& level, const Dictionary& dict,
                                                              const LevelBuildSettings& settings) {
  ShapedOperatorCache local;
  ShapedOperatorCache& cache = settings.shaped_cache ? *settings.shaped_cache : local;
  const int steps = settings.proportion_steps_per_octave;
  const bool traced_interfaces = settings.interface_basis && !dict.interfaces.empty();
  std::map<std::pair<int, ProportionSteps>, int> index;
  std::vector<ShapedInterfaces> interfaces;
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    LevelBlock& b = level.blocks[i];
    const bool connected = std::any_of(b.neighbour.begin(), b.neighbour.end(), [](int n) { return n >= 0; });
    if (connected && !traced_interfaces) continue;
    const ProportionSteps q = quantise_proportions(block_box_extent(b), steps);
    if (q == ProportionSteps{}) continue;
    auto [it, inserted] = index.try_emplace({b.shape, q}, int(level.shaped.size()));
    if (inserted) {
      Result<ShapedOperators> ops = cache.get(dict, b.shape, q, steps);
      if (!ops.ok())
        return Status::error(ops.status().code(),
                             "block " + std::to_string(i) + ": " + ops.status().message());
      level.shaped.push_back(std::move(ops.value()));
      interfaces.emplace_back();
    }
    const std::size_t set = std::size_t(it->second);
    if (connected && interfaces[set].empty()) {
      Result<ShapedInterfaces> traced =
          cache.interfaces(dict, *settings.interface_basis, level.shaped[set], q, steps);
      if (!traced.ok())
        return Status::error(traced.status().code(),
                             "block " + std::to_string(i) + ": " + traced.status().message());
      interfaces[set] = std::move(traced.value());
      level.shaped[set].operators.Rb_rlf = interfaces[set].Rb_rlf;
    }
    b.shaped = int(set);
  }
  return interfaces;
}

}  // namespace

std::uint64_t estimate_level_bytes(const LevelDescription& description, const Dictionary& dict,
                                   const LevelBuildSettings& settings) {
  const double res = dict.settings.res, kb = dict.settings.kb, kr = dict.interfaces.Ur.cols;
  double samples = 0.0, slots = 0.0;
  for (const BlockDescription& b : description.blocks) {
    samples += double(face_count(b.faces)) * res * res;
    for (int f : {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ}) slots += face_present(b.faces, f) ? 0.0 : 1.0;
  }
  // Blocks within dmax interfaces of a slot in a 2D grid: at most 2 dmax^2 + 2 dmax + 1.
  const double d = std::max(settings.dmax, 0);
  const double sources = std::min(double(description.blocks.size()), 2.0 * d * d + 2.0 * d + 1.0);
  const double bytes = samples * 4.0 * 12.0 + slots * sources * kr * kb * 4.0;
  return bytes >= 1.8e19 ? std::numeric_limits<std::uint64_t>::max() : std::uint64_t(bytes);
}

Status validate_level_build_settings(const LevelBuildSettings& settings) {
  if (settings.dmax < 0 || settings.dmax > kMaxLevelDmax)
    return Status::error(ErrorCode::invalid_argument, "build_level: dmax = " + std::to_string(settings.dmax) +
                                                          ": must be in [0, " +
                                                          std::to_string(kMaxLevelDmax) + "]");
  if (settings.proportion_steps_per_octave < 1 || settings.proportion_steps_per_octave > kMaxProportionSteps)
    return Status::error(
        ErrorCode::invalid_argument,
        "build_level: proportion_steps_per_octave = " + std::to_string(settings.proportion_steps_per_octave) +
            ": must be in [1, " + std::to_string(kMaxProportionSteps) + "]");
  return Status::success();
}

Result<Level> build_level_layout(const LevelDescription& description, int res) {
  if (res < 1 || res > int(kMaxSettingsRes))
    return Status::error(ErrorCode::invalid_argument, "build_level_layout: res = " + std::to_string(res) +
                                                          ": must be in [1, " +
                                                          std::to_string(kMaxSettingsRes) + "]");
  Result<LevelConnectivity> connectivity = validate_level(description);
  if (!connectivity.ok()) return connectivity.status();
  Level level;
  level.res = res;
  const std::size_t count = description.blocks.size();
  level.blocks.resize(count);
  std::uint32_t offset = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const BlockDescription& d = description.blocks[i];
    Result<ShapeOrientation> o = canonicalise_face_mask(d.faces);
    if (!o.ok())
      return Status::error(o.status().code(), "block " + std::to_string(i) + ": " + o.status().message());
    LevelBlock& b = level.blocks[i];
    b.shape = o->shape;
    b.quarter_turns = o->quarter_turns;
    b.cell = d.cell;
    b.corners = block_corners(description, d);
    for (int f = 0; f < kFaceCount; ++f) {
      const int world = rotate_face(f, b.quarter_turns);
      b.neighbour[std::size_t(f)] = connectivity->connected[i][std::size_t(world)]
                                        ? connectivity->neighbour[i][std::size_t(world)]
                                        : -1;
      b.albedo[std::size_t(f)] = glm::vec3(d.albedo[std::size_t(world)]);
    }
    b.sample_offset = offset;
    b.sample_count = std::uint32_t(face_count(dictionary_shape_mask(b.shape)) * level.res * level.res);
    offset += b.sample_count;
  }
  level.sample_count = offset;
  build_atlas(level);
  return level;
}

Result<Level> build_level(const LevelDescription& description, const Dictionary& dict,
                          const LevelBuildSettings& settings) {
  if (Status s = validate_level_build_settings(settings); !s.ok()) return s;
  if (const std::uint64_t need = estimate_level_bytes(description, dict, settings);
      need > settings.memory_budget_bytes) {
    char text[256];
    std::snprintf(
        text, sizeof text,
        "build_level: %zu blocks at res %u would need up to %.1f GiB (run-time signals and Tb->r "
        "records within dmax %d), over the memory budget of %.1f GiB: split the level, lower res or "
        "dmax, or raise LevelBuildSettings::memory_budget_bytes",
        description.blocks.size(), dict.settings.res, double(need) / double(1u << 30), settings.dmax,
        double(settings.memory_budget_bytes) / double(1u << 30));
    return Status::error(ErrorCode::resource_limit, text);
  }
  if (dict.interfaces.empty())
    return Status::error(
        ErrorCode::invalid_argument,
        "build_level: the dictionary has no interface operators (baked with lightfield_spatial = 0)");
  Result<Level> laid_out = build_level_layout(description, int(dict.settings.res));
  if (!laid_out.ok()) return laid_out.status();
  Level level = std::move(laid_out.value());
  level.kb = dict.settings.kb;
  level.kr = dict.interfaces.Ur.cols;
  const std::size_t count = description.blocks.size();
  std::vector<ShapedInterfaces> shaped_interfaces;
  if (settings.shaped_operators) {
    Result<std::vector<ShapedInterfaces>> assigned = assign_shaped_operators(level, dict, settings);
    if (!assigned.ok()) return assigned.status();
    shaped_interfaces = std::move(assigned.value());
  }
  level.kb = level_b_stride(dict, level);  // shaped sets may keep more modes than a cube
  // The interface operators of block b: its box's where they were traced, else the cube's.
  auto box_interfaces = [&](const LevelBlock& b) -> const ShapedInterfaces* {
    return b.shaped >= 0 && !shaped_interfaces[std::size_t(b.shaped)].empty()
               ? &shaped_interfaces[std::size_t(b.shaped)]
               : nullptr;
  };

  // Response slots: one per (block, connected canonical side face).
  const SampleLayout dead_end = SampleLayout::make(dictionary_shape_mask(1), level.res);
  std::vector<std::array<int, kFaceCount>> slot_of(count);
  for (std::size_t i = 0; i < count; ++i) {
    slot_of[i].fill(-1);
    const LevelBlock& b = level.blocks[i];
    const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(b.shape), level.res);
    for (int e = 0; e < kFaceCount; ++e) {
      if (b.neighbour[std::size_t(e)] < 0) continue;
      ResponseSlot slot;
      slot.block = std::uint32_t(i);
      slot.entry_face = e;
      slot.ur_row_to_sample.assign(std::size_t(dead_end.sample_count()), -1);
      const int turns = turns_to_face(e);
      for (int s = 0; s < dead_end.sample_count(); ++s) {
        const int f = dead_end.face_of(s), t = s % dead_end.texels_per_face();
        int f2, i2, j2;
        rotate_texel(f, t % level.res, t / level.res, level.res, turns, f2, i2, j2);
        if (face_present(layout.mask, f2)) slot.ur_row_to_sample[std::size_t(s)] = layout.index(f2, i2, j2);
      }
      slot_of[i][std::size_t(e)] = int(level.slots.size());
      level.slots.push_back(std::move(slot));
    }
  }

  // Breadth-first propagation from every block (MRT §6.3). Transport is linear, so all
  // paths reaching the same (block, entry face) at the same depth are summed before they
  // propagate further: the cost grows with depth x blocks, not with the number of paths
  // (which is exponential in dmax once a maze has loops). Paths reaching the same
  // (source, slot) at any depth are summed into one record.
  const MatrixXd Trlf_r = to_eigen(dict.interfaces.Trlf_r);
  const std::array<MatrixXd, 3> R = {to_eigen(dict.interfaces.R_straight), to_eigen(dict.interfaces.R_left),
                                     to_eigen(dict.interfaces.R_right)};
  // Shaped boxes' R and Trlf_r in double, converted once per (set, faces).
  std::map<std::tuple<int, int, int>, MatrixXd> box_R;
  std::map<std::pair<int, int>, MatrixXd> box_Trlf_r;
  auto propagation = [&](const LevelBlock& b, int entry, int exit, Propagation dir) -> const MatrixXd& {
    const ShapedInterfaces* box = box_interfaces(b);
    if (!box) return R[std::size_t(dir)];
    auto [it, inserted] = box_R.try_emplace({b.shaped, entry, exit});
    if (inserted) it->second = to_eigen(box->R[std::size_t(entry)][std::size_t(exit)]);
    return it->second;
  };
  auto response = [&](const LevelBlock& b, int entry) -> const MatrixXd& {
    const ShapedInterfaces* box = box_interfaces(b);
    if (!box) return Trlf_r;
    auto [it, inserted] = box_Trlf_r.try_emplace({b.shaped, entry});
    if (inserted) it->second = to_eigen(box->Trlf_r[std::size_t(entry)]);
    return it->second;
  };
  for (std::size_t src = 0; src < count; ++src) {
    const LevelBlock& sb = level.blocks[src];
    std::map<int, MatrixXd> accumulated;                     // slot -> krlf x kb lightfield sum
    std::map<std::pair<int, int>, MatrixXd> frontier, next;  // (block, canonical entry) -> krlf x kb
    auto add = [](std::map<std::pair<int, int>, MatrixXd>& m, std::pair<int, int> key, MatrixXd A) {
      auto [it, inserted] = m.try_emplace(key, std::move(A));
      if (!inserted) it->second += A;
    };
    for (int f = 0; f < kFaceCount; ++f) {
      const int nb = sb.neighbour[std::size_t(f)];
      if (nb < 0) continue;
      const int entry_world = rotate_face(f, sb.quarter_turns) ^ 1;
      const int entry = rotate_face(entry_world, -level.blocks[std::size_t(nb)].quarter_turns);
      add(frontier, {nb, entry}, to_eigen(block_operators(dict, level, sb).Rb_rlf[std::size_t(f)]));
    }
    for (int depth = 1; depth <= settings.dmax && !frontier.empty(); ++depth) {
      next.clear();
      for (const auto& [key, A] : frontier) {
        const auto [block, entry] = key;
        const LevelBlock& b = level.blocks[std::size_t(block)];
        const int slot = slot_of[std::size_t(block)][std::size_t(entry)];
        auto [it, inserted] = accumulated.try_emplace(slot, A);
        if (!inserted) it->second += A;
        if (depth == settings.dmax) continue;
        for (int f = 0; f < kFaceCount; ++f) {
          const int nb = b.neighbour[std::size_t(f)];
          Propagation dir;
          if (nb < 0 || f == entry || !classify_propagation(entry, f, dir)) continue;
          const int entry_world = rotate_face(f, b.quarter_turns) ^ 1;
          const int nb_entry = rotate_face(entry_world, -level.blocks[std::size_t(nb)].quarter_turns);
          add(next, {nb, nb_entry}, propagation(b, entry, f, dir) * A);
        }
      }
      frontier.swap(next);
    }
    for (const auto& [slot, A] : accumulated) {
      const ResponseSlot& rs = level.slots[std::size_t(slot)];
      level.records.push_back({std::uint32_t(src), std::uint32_t(slot),
                               to_float(response(level.blocks[rs.block], rs.entry_face) * A)});
    }
  }
  if (!dict.interfaces.Urvol.empty())
    for (int f : {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ})
      level.probe_response[std::size_t(f)] =
          turned_probe_response(dict.interfaces.Urvol, int(dict.settings.probe_grid), f);
  if (!dict.interfaces.Ur_vec.empty())
    for (int f : {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ})
      level.vector_response[std::size_t(f)] = turned_vector_response(dict.interfaces.Ur_vec, level.res, f);
  std::stable_sort(level.records.begin(), level.records.end(),
                   [](const ResponseRecord& a, const ResponseRecord& b) { return a.slot < b.slot; });
  return level;
}

}  // namespace modrt::precompute
