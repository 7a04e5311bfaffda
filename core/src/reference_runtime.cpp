// SPDX-License-Identifier: MIT
#include "modrt/reference_runtime.h"
#include "modrt/feedback_policy.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace modrt {
namespace {

void apply_rgb(const Matrix& A, std::span<const float> in, std::span<float> out) {
  reference_gemv_rgb(A, in.data(), out.data(), false);
}

}  // namespace

void reference_gemv_rgb(const Matrix& A, const float* in, float* out, bool accumulate) {
  for (std::uint32_t r = 0; r < A.rows; ++r) {
    const float* row = A.data.data() + std::size_t(r) * A.cols;
    double acc[3] = {0.0, 0.0, 0.0};
    for (std::uint32_t k = 0; k < A.cols; ++k) {
      const double a = row[k];
      acc[0] += a * in[3 * k + 0];
      acc[1] += a * in[3 * k + 1];
      acc[2] += a * in[3 * k + 2];
    }
    for (int c = 0; c < 3; ++c) out[3 * r + c] = float((accumulate ? double(out[3 * r + c]) : 0.0) + acc[c]);
  }
}

Result<FeedbackClamp> prepare_feedback(std::span<const float> ld_direct, std::span<const float> albedo,
                                       std::size_t samples, const MultiBounceSettings& settings) {
  if (Status s = validate_light_signal(ld_direct, samples, "ld_direct"); !s.ok()) return s;
  if (Status s = validate_light_signal(albedo, samples, "albedo"); !s.ok()) return s;
  if (Status s = check_max_albedo(settings.max_albedo, "multi-bounce: settings"); !s.ok()) return s;
  if (settings.max_iterations < 1)
    return Status::error(ErrorCode::invalid_argument, "multi-bounce: settings.max_iterations must be >= 1");
  FeedbackClamp clamp;
  clamp.rho.resize(albedo.size());
  const ClampedAlbedo rho = clamp_albedo(albedo, settings.max_albedo, clamp.rho);
  clamp.albedo_clamped = rho.clamped;
  clamp.energy_bound = feedback_energy_bound(largest_light(ld_direct), rho.rho_max);
  return clamp;
}

void clamp_lightmap(std::span<float> lightmap) {
  for (float& v : lightmap) v = nonnegative_light(v);
}

bool apply_feedback(const FeedbackClamp& clamp, std::span<const float> ld_direct,
                    std::span<const float> lightmap, std::span<float> ld) {
  bool clamped = false;
  for (std::size_t i = 0; i < ld.size(); ++i) {
    float l = nonnegative_light(lightmap[i]);
    if (l > clamp.energy_bound) {
      l = clamp.energy_bound;
      clamped = true;
    }
    ld[i] = ld_direct[i] + clamp.rho[i] * l;
  }
  return clamped;
}

bool feedback_converged(std::span<const float> b, std::span<const float> b_prev, float tolerance) {
  float delta = 0.0f, scale = 0.0f;
  for (std::size_t k = 0; k < b.size(); ++k) {
    delta = std::max(delta, std::abs(b[k] - b_prev[k]));
    scale = std::max(scale, std::abs(b[k]));
  }
  return delta <= tolerance * scale;
}

Status validate_light_signal(std::span<const float> rgb, std::size_t samples, const char* what) {
  if (rgb.size() != 3 * samples)
    return Status::error(ErrorCode::invalid_argument, std::string(what) + ": has " +
                                                          std::to_string(rgb.size()) +
                                                          " floats, expected 3 x " + std::to_string(samples));
  // Fast path, every frame: one branch-free pass over the bit patterns (vectorised integer
  // compares). A float in [+0, kMaxLightValue] has its sign bit clear and, read as an
  // integer, is at most kMaxLightValue's pattern; NaN, Inf, negative and too large values are not
  // (nor is -0, which the loop below then accepts). That loop, which names the first bad
  // value, runs only when the pass found one.
  // Read as unsigned, a set sign bit is larger than any finite positive pattern: one compare.
  // Blocks of 16 give the compiler a fixed trip count it vectorises at -O2.
  constexpr std::uint32_t kMaxBits = std::bit_cast<std::uint32_t>(kMaxLightValue);
  const auto out_of_range = [](float v) { return std::uint32_t(std::bit_cast<std::uint32_t>(v) > kMaxBits); };
  std::uint32_t bad = 0;
  std::size_t at = 0;
  for (; at + 16 <= rgb.size(); at += 16) {
    std::uint32_t block = 0;
    for (std::size_t k = 0; k < 16; ++k) block |= out_of_range(rgb[at + k]);
    bad |= block;
  }
  for (; at < rgb.size(); ++at) bad |= out_of_range(rgb[at]);
  if (bad == 0) return Status::success();
  static constexpr const char* kChannel[3] = {"R", "G", "B"};
  for (std::size_t i = 0; i < rgb.size(); ++i) {
    const float v = rgb[i];
    if (!std::isfinite(v))
      return Status::error(ErrorCode::non_finite, std::string(what) + ": sample " + std::to_string(i / 3) +
                                                      " channel " + kChannel[i % 3] + " is " +
                                                      (std::isnan(v) ? "NaN" : "Inf"));
    if (v < 0.0f)
      return Status::error(ErrorCode::invalid_argument,
                           std::string(what) + ": sample " + std::to_string(i / 3) + " channel " +
                               kChannel[i % 3] + " is negative (" + std::to_string(v) + ")");
    if (v > kMaxLightValue) {
      char value[32];
      std::snprintf(value, sizeof value, "%g", double(v));
      return Status::error(
          ErrorCode::invalid_argument,
          std::string(what) + ": sample " + std::to_string(i / 3) + " channel " + kChannel[i % 3] + " is " +
              value + ", above the largest light value 1e30 (kMaxLightValue): rescale the scene's light");
    }
  }
  return Status::success();
}

Status compute_b(const ShapeOperators& op, std::span<const float> ld, std::span<float> b) {
  if (Status s = validate_light_signal(ld, op.Td_b.cols, "ld"); !s.ok()) return s;
  if (b.size() != 3 * std::size_t(op.Td_b.rows))
    return Status::error(
        ErrorCode::invalid_argument,
        "b: has " + std::to_string(b.size()) + " floats, expected 3 x " + std::to_string(op.Td_b.rows));
  apply_rgb(op.Td_b, ld, b);
  return Status::success();
}

void apply_Ub(const ShapeOperators& op, std::span<const float> b, std::span<float> lightmap) {
  apply_rgb(op.Ub, b, lightmap);
  clamp_lightmap(lightmap);
}

void apply_Ub_vec(const ShapeOperators& op, std::span<const float> b, std::span<float> out) {
  apply_rgb(op.Ub_vec, b, out);
}

void apply_Ubvol(const ShapeOperators& op, std::span<const float> b, std::span<float> out) {
  apply_rgb(op.Ubvol, b, out);
}

Result<MultiBounceReport> multi_bounce(const ShapeOperators& op, std::span<const float> ld_direct,
                                       std::span<const float> albedo, const MultiBounceSettings& settings,
                                       std::span<float> b, std::span<float> lightmap) {
  const std::size_t n = op.sample_count();
  Result<FeedbackClamp> clamp = prepare_feedback(ld_direct, albedo, n, settings);
  if (!clamp.ok()) return clamp.status();
  if (lightmap.size() != 3 * n || b.size() != 3 * std::size_t(op.kb()))
    return Status::error(ErrorCode::invalid_argument, "multi_bounce: output spans have the wrong size");
  MultiBounceReport report;
  report.albedo_clamped = clamp->albedo_clamped;
  report.energy_bound = clamp->energy_bound;
  std::vector<float> ld(ld_direct.begin(), ld_direct.end());
  std::vector<float> b_prev(b.size(), 0.0f);
  apply_rgb(op.Td_b, ld, b);
  for (int it = 1; it <= settings.max_iterations; ++it) {
    apply_Ub(op, b, lightmap);
    report.value_clamped |= apply_feedback(clamp.value(), ld_direct, lightmap, ld);
    std::copy(b.begin(), b.end(), b_prev.begin());
    apply_rgb(op.Td_b, ld, b);
    report.iterations = it;
    if (feedback_converged(b, b_prev, settings.tolerance)) {
      report.converged = true;
      break;
    }
  }
  apply_Ub(op, b, lightmap);
  return report;
}

}  // namespace modrt
