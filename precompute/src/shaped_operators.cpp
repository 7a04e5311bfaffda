// SPDX-License-Identifier: MIT
#include "modrt/precompute/shaped_operators.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>

#include <glm/geometric.hpp>

#include "modrt/level_io.h"
#include "modrt/precompute/bake.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/linalg.h"
#include "modrt/precompute/matrix_file.h"

namespace modrt::precompute {
namespace {

std::string extent_text(const glm::dvec3& e) {
  char text[96];
  std::snprintf(text, sizeof text, "%.4g x %.4g x %.4g", e.x, e.y, e.z);
  return text;
}

}  // namespace

glm::dvec3 block_box_extent(const LevelBlock& block) {
  // Corner index x + 2y + 4z in world axes; the four edges along axis a join corners c and
  // c + (1 << a).
  const auto& c = block.corners;
  glm::dvec3 world(0.0);
  for (int a = 0; a < 3; ++a) {
    const int bit = 1 << a;
    for (int k = 0; k < 8; ++k)
      if (!(k & bit)) world[a] += 0.25 * glm::length(c[std::size_t(k | bit)] - c[std::size_t(k)]);
  }
  // Canonical x and z are world z and x after an odd number of quarter turns about y.
  return block.quarter_turns % 2 ? glm::dvec3(world.z, world.y, world.x) : world;
}

ProportionSteps quantise_proportions(const glm::dvec3& extent, int steps_per_octave) {
  // Clamp each edge to within kMaxShapedAspect of the shortest, then centre on the log mean.
  const double shortest = std::log2(std::min({extent.x, extent.y, extent.z}));
  double l[3], mean_log = 0.0;
  for (int a = 0; a < 3; ++a) {
    l[a] = std::min(std::log2(extent[a]), shortest + std::log2(kMaxShapedAspect));
    mean_log += l[a] / 3.0;
  }
  ProportionSteps q{};
  for (int a = 0; a < 3; ++a) q[std::size_t(a)] = int(std::lround(steps_per_octave * (l[a] - mean_log)));
  return q;
}

glm::dvec3 proportions_extent(const ProportionSteps& steps, int steps_per_octave) {
  glm::dvec3 e;
  double mean = 0.0;
  for (int a = 0; a < 3; ++a) mean += double(steps[std::size_t(a)]) / 3.0;
  for (int a = 0; a < 3; ++a) e[a] = std::exp2((double(steps[std::size_t(a)]) - mean) / steps_per_octave);
  return e;
}

int shaped_mode_factor(const glm::dvec3& extent) {
  double e[3] = {extent.x, extent.y, extent.z};
  std::sort(e, e + 3);
  const double shortest = std::max(e[0], 0.5 * e[1]);
  if (!(shortest > 0.0) || !std::isfinite(e[2])) return 1;
  const double cubes = e[0] * e[1] * e[2] / (shortest * shortest * shortest);
  // 1.1: the proportion lattice's rounding (a 3 x 1 x 1 box is baked as 2.83 cubes at 8 steps
  // an octave) must not cost a mode factor.
  return int(std::clamp(std::floor(1.1 * cubes), 1.0, double(kMaxShapedModeFactor)));
}

DictionarySettings shaped_bake_settings(const DictionarySettings& dict, FaceMask mask,
                                        const glm::dvec3& extent) {
  DictionarySettings s = dict;
  const std::uint32_t m = std::uint32_t(shaped_mode_factor(extent));
  const std::uint32_t samples = std::uint32_t(face_count(mask)) * dict.res * dict.res;
  s.kb = std::max(dict.kb, std::min(dict.kb * m, samples));
  // The prior keeps kd (3m - 1) modes: the stretched lattice holds m times the lights, and Ub
  // reduced from a richer prior is closer to F (docs/precompute.md: the 3 x 1 x 1 room's
  // camera error 0.057 / 0.053 / 0.052 / 0.051 / 0.051 at kd x 3 / 5 / 6 / 8 / 12).
  const std::uint32_t prior = m > 1 ? dict.kd * (3 * m - 1) : dict.kd;
  s.kd = std::max(dict.kd, std::min(prior, std::max(samples, s.kb)));
  return s;
}

Result<ShapedOperators> bake_shaped_operators(const Dictionary& dict, int shape, const glm::dvec3& extent) {
  const std::string what =
      "shaped operators for shape " + std::to_string(shape) + ", box " + extent_text(extent);
  if (shape < 0 || std::size_t(shape) >= dict.shapes.size())
    return Status::error(ErrorCode::invalid_argument, what + ": no such dictionary shape");
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(extent[a]) || !(extent[a] > 0.0))
      return Status::error(ErrorCode::invalid_argument, what + ": the extent must be finite and > 0");
  try {
    const ShapeOperators& cube = dict.shapes[std::size_t(shape)];
    const bool with_sh = !cube.Ub_vec.empty();
    ShapeBake bake = bake_box_shape(cube.face_mask, extent,
                                    shaped_bake_settings(dict.settings, cube.face_mask, extent), with_sh);
    ShapedOperators out;
    out.shape = shape;
    out.extent = glm::vec3(extent);
    out.operators = to_operators(bake);
    if (!with_sh) out.operators.Ub_vec = cube.Ub_vec, out.operators.Ubvol = cube.Ubvol;
    for (const Matrix* m : {&out.operators.Ub, &out.operators.Td_b, &out.operators.Limp})
      for (float v : m->data)
        if (!std::isfinite(v))
          return Status::error(ErrorCode::non_finite, what + ": the bake produced NaN or Inf");
    return out;
  } catch (const std::bad_alloc&) {
    return Status::error(ErrorCode::resource_limit, what + ": out of memory");
  } catch (const std::exception& e) {
    return Status::error(ErrorCode::internal_error, what + ": " + e.what());
  }
}

Result<ShapedOperators> ShapedOperatorCache::get(const Dictionary& dict, int shape,
                                                 const ProportionSteps& steps, int steps_per_octave) {
  const Key key{dict.settings, shape, steps_per_octave, steps};
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const Entry& e : entries_)
      if (e.key == key) {
        ++hits_;
        return e.operators;
      }
  }
  Result<ShapedOperators> found = load_or_bake(dict, shape, steps, steps_per_octave);
  if (!found.ok()) return found;
  const std::lock_guard<std::mutex> lock(mutex_);
  entries_.push_back({key, found.value()});
  return found;
}

std::string ShapedOperatorCache::file_name(const DictionarySettings& settings, int shape,
                                           const ProportionSteps& steps, int steps_per_octave) {
  // Named by the settings the set is baked with (its kb and kd: shaped_bake_settings), so a
  // change of that policy never loads an older bake.
  const glm::dvec3 extent = proportions_extent(steps, steps_per_octave);
  std::string stem = cache_file_name(shaped_bake_settings(settings, dictionary_shape_mask(shape), extent));
  if (const std::size_t dot = stem.rfind('.'); dot != std::string::npos) stem.resize(dot);
  return "shaped-" + stem + "-s" + std::to_string(shape) + "-o" + std::to_string(steps_per_octave) + "-" +
         std::to_string(steps[0]) + "_" + std::to_string(steps[1]) + "_" + std::to_string(steps[2]) +
         ".modrtlevel";
}

Result<ShapedOperators> ShapedOperatorCache::load_or_bake(const Dictionary& dict, int shape,
                                                          const ProportionSteps& steps,
                                                          int steps_per_octave) {
  const std::string path = directory_.empty()
                               ? std::string()
                               : directory_ + "/" + file_name(dict.settings, shape, steps, steps_per_octave);
  const glm::vec3 extent(proportions_extent(steps, steps_per_octave));
  if (!path.empty() && std::filesystem::exists(path)) {
    Result<Level> saved = load_level(path);
    // The entry must be what its name says (a file renamed or written by another build).
    if (saved.ok() && saved->shaped.size() == 1 && saved->shaped[0].shape == shape &&
        saved->shaped[0].extent == extent && std::uint32_t(saved->res) == dict.settings.res &&
        saved->kb <=
            shaped_bake_settings(dict.settings, dictionary_shape_mask(shape), glm::dvec3(extent)).kb &&
        saved->shaped[0].operators.Ub.cols == saved->kb &&
        saved->shaped[0].operators.Ubvol.rows == dict.shapes[0].Ubvol.rows) {
      ShapedOperators out = std::move(saved->shaped[0]);
      const std::lock_guard<std::mutex> lock(mutex_);
      ++disk_loads_;
      return out;
    }
  }
  Result<ShapedOperators> baked = bake_shaped_operators(dict, shape, glm::dvec3(extent));
  if (!baked.ok()) return baked;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    ++bakes_;
  }
  if (!path.empty()) {
    // A level with no block that holds the one set; a cache that cannot be written only
    // costs the next process a bake.
    Level entry;
    entry.res = int(dict.settings.res);
    entry.kb = baked->operators.Ub.cols;  // the set's modes (shaped_bake_settings)
    entry.kr = dict.interfaces.Ur.cols;
    entry.shaped.push_back(baked.value());
    std::error_code ec;
    std::filesystem::create_directories(directory_, ec);
    (void)save_level(path, entry);
  }
  return baked;
}

Result<ShapedInterfaces> ShapedOperatorCache::interfaces(const Dictionary& dict, const Matrix& Hrlf,
                                                         const ShapedOperators& ops,
                                                         const ProportionSteps& steps, int steps_per_octave) {
  const Key key{dict.settings, ops.shape, steps_per_octave, steps};
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const InterfaceEntry& e : interface_entries_)
      if (e.key == key) {
        ++hits_;
        return e.interfaces;
      }
  }
  Result<ShapedInterfaces> found = load_or_bake_interfaces(dict, Hrlf, ops, steps, steps_per_octave);
  if (!found.ok()) return found;
  const std::lock_guard<std::mutex> lock(mutex_);
  interface_entries_.push_back({key, found.value()});
  return found;
}

namespace {

// An interface entry's non-empty matrices and their names in its file.
std::vector<std::pair<std::string, Matrix*>> interface_matrices(ShapedInterfaces& in) {
  std::vector<std::pair<std::string, Matrix*>> out;
  for (int e = 0; e < kFaceCount; ++e) {
    const std::string f = std::to_string(e);
    if (!in.Rb_rlf[std::size_t(e)].empty()) out.emplace_back("Rb_rlf " + f, &in.Rb_rlf[std::size_t(e)]);
    if (!in.Trlf_r[std::size_t(e)].empty()) out.emplace_back("Trlf_r " + f, &in.Trlf_r[std::size_t(e)]);
    for (int x = 0; x < kFaceCount; ++x)
      if (!in.R[std::size_t(e)][std::size_t(x)].empty())
        out.emplace_back("R " + f + " " + std::to_string(x), &in.R[std::size_t(e)][std::size_t(x)]);
  }
  return out;
}

}  // namespace

Result<ShapedInterfaces> ShapedOperatorCache::load_or_bake_interfaces(const Dictionary& dict,
                                                                      const Matrix& Hrlf,
                                                                      const ShapedOperators& ops,
                                                                      const ProportionSteps& steps,
                                                                      int steps_per_octave) {
  std::string path;
  if (!directory_.empty()) {
    path = directory_ + "/" + file_name(dict.settings, ops.shape, steps, steps_per_octave);
    path.resize(path.size() - std::string(".modrtlevel").size());
    path += ".lfops";
  }
  const std::string tag = "modrt shaped interfaces of " + std::filesystem::path(path).filename().string();
  const std::string what = "shaped interfaces for shape " + std::to_string(ops.shape) + ", box " +
                           extent_text(glm::dvec3(ops.extent));
  // The sizes a bake produces: the shape's missing side faces, the dictionary's counts.
  const FaceMask mask = dictionary_shape_mask(ops.shape);
  const std::uint32_t krlf = dict.settings.krlf, kb = ops.operators.Ub.cols, kr = dict.interfaces.Ur.cols;
  ShapedInterfaces expected;
  for (int e : {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ}) {
    if (face_present(mask, e)) continue;
    expected.Rb_rlf[std::size_t(e)] = Matrix(krlf, kb);
    expected.Trlf_r[std::size_t(e)] = Matrix(kr, krlf);
    for (int x : {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ})
      if (x != e && !face_present(mask, x)) expected.R[std::size_t(e)][std::size_t(x)] = Matrix(krlf, krlf);
  }
  if (!path.empty() && std::filesystem::exists(path)) {
    Result<std::vector<NamedMatrix>> saved = load_matrix_file(path, tag);
    const auto want = interface_matrices(expected);
    bool usable = saved.ok() && saved->size() == want.size();
    for (std::size_t i = 0; usable && i < want.size(); ++i) {
      NamedMatrix& m = saved.value()[i];
      usable = m.name == want[i].first && m.matrix.rows == want[i].second->rows &&
               m.matrix.cols == want[i].second->cols;
      if (usable) *want[i].second = std::move(m.matrix);
    }
    if (usable) {
      const std::lock_guard<std::mutex> lock(mutex_);
      ++disk_loads_;
      return expected;
    }
  }
  ShapedInterfaces out;
  try {
    out = bake_shaped_interfaces(dict, Hrlf, ops.shape, glm::dvec3(ops.extent), ops.operators.Limp);
  } catch (const std::bad_alloc&) {
    return Status::error(ErrorCode::resource_limit, what + ": out of memory");
  } catch (const std::exception& e) {
    return Status::error(ErrorCode::invalid_argument, what + ": " + e.what());
  }
  for (const auto& [name, m] : interface_matrices(out))
    for (float v : m->data)
      if (!std::isfinite(v))
        return Status::error(ErrorCode::non_finite, what + ": " + name + " holds NaN or Inf");
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    ++bakes_;
  }
  if (!path.empty()) {
    // A cache that cannot be written only costs the next process a bake.
    std::error_code ec;
    std::filesystem::create_directories(directory_, ec);
    std::vector<MatrixRef> refs;
    for (const auto& [name, m] : interface_matrices(out)) refs.push_back({name, m});
    (void)save_matrix_file(path, tag, refs);
  }
  return out;
}

std::size_t ShapedOperatorCache::disk_loads() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return disk_loads_;
}

std::size_t ShapedOperatorCache::bakes() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return bakes_;
}

std::size_t ShapedOperatorCache::hits() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return hits_;
}

}  // namespace modrt::precompute
