// SPDX-License-Identifier: MIT
#include "modrt/reduced_feedback.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "modrt/feedback_policy.h"
#include "modrt/level_runtime.h"
#include "modrt/reference_runtime.h"

namespace modrt {
namespace {

// acc[3 (k cols + j) + c] += sum over the rows m of `left` (k, m) rho(m, c) right(m, j) for one
// block: left is Td_b (kb x n, column m = block sample m), right is Ub (n x kb) or Ur (one row
// per dead-end sample, mapped to block samples by row_to_sample; nullptr: the identity).
void accumulate_weighted_product(const Matrix& left, std::span<const float> rho_block, const Matrix& right,
                                 const std::int32_t* row_to_sample, std::vector<double>& acc) {
  const std::uint32_t kb = left.rows, cols = right.cols;
  for (std::uint32_t k = 0; k < kb; ++k) {
    double* out = acc.data() + 3 * std::size_t(k) * cols;
    for (std::uint32_t m = 0; m < right.rows; ++m) {
      const std::int32_t sample = row_to_sample ? row_to_sample[m] : std::int32_t(m);
      if (sample < 0) continue;
      const double t = left(k, std::uint32_t(sample));
      const double w0 = t * rho_block[3 * std::size_t(sample) + 0],
                   w1 = t * rho_block[3 * std::size_t(sample) + 1],
                   w2 = t * rho_block[3 * std::size_t(sample) + 2];
      if (w0 == 0.0 && w1 == 0.0 && w2 == 0.0) continue;
      const float* row = right.data.data() + std::size_t(m) * cols;
      for (std::uint32_t j = 0; j < cols; ++j) {
        const double u = row[j];
        out[3 * j + 0] += w0 * u;
        out[3 * j + 1] += w1 * u;
        out[3 * j + 2] += w2 * u;
      }
    }
  }
}

ChannelMatrix to_channel_matrix(std::uint32_t rows, std::uint32_t cols, const std::vector<double>& acc) {
  ChannelMatrix m{rows, cols, std::vector<float>(acc.size())};
  for (std::size_t i = 0; i < acc.size(); ++i) m.data[i] = float(acc[i]);
  return m;
}

// Power iteration on M (undamped): the growth per application of each channel's norm over the
// last iterations, largest over the channels. Deterministic start with every entry non-zero.
double estimate_spectral_radius(const Level& level, const LevelDependencies& deps,
                                const ReducedFeedback& op) {
  const std::size_t n = 3 * std::size_t(op.kb) * level.blocks.size();
  if (n == 0) return 0.0;
  std::vector<float> x(n), y(n), r(3 * std::size_t(op.kr) * level.slots.size());
  std::uint32_t seed = 12345u;
  for (float& v : x) {
    seed = seed * 1664525u + 1013904223u;
    v = 0.5f + float(seed >> 8) / float(1u << 24);
  }
  constexpr int kWarmup = 40, kMeasured = 24;
  double log_growth[3] = {0.0, 0.0, 0.0};
  for (int it = 0; it < kWarmup + kMeasured; ++it) {
    reference_apply_reduced_feedback(level, deps, op, x, r, y);
    for (int c = 0; c < 3; ++c) {
      double before = 0.0, after = 0.0;
      for (std::size_t i = std::size_t(c); i < n; i += 3)
        before += double(x[i]) * x[i], after += double(y[i]) * y[i];
      before = std::sqrt(before), after = std::sqrt(after);
      if (it >= kWarmup) log_growth[c] += (after > 0.0 && before > 0.0) ? std::log(after / before) : -60.0;
      // Normalised per channel so that no channel underflows or overflows.
      const double scale = after > 0.0 ? 1.0 / after : 0.0;
      for (std::size_t i = std::size_t(c); i < n; i += 3) x[i] = float(double(y[i]) * scale);
    }
  }
  double q = 0.0;
  for (double g : log_growth) q = std::max(q, std::exp(g / kMeasured));
  return q;
}

}  // namespace

void reference_gemv_channels(const ChannelMatrix& M, const float* in, float* out, bool accumulate) {
  for (std::uint32_t r = 0; r < M.rows; ++r) {
    const float* row = M.data.data() + 3 * std::size_t(r) * M.cols;
    double acc[3] = {0.0, 0.0, 0.0};
    for (std::uint32_t k = 0; k < M.cols; ++k)
      for (int c = 0; c < 3; ++c) acc[c] += double(row[3 * k + c]) * in[3 * k + c];
    for (int c = 0; c < 3; ++c) out[3 * r + c] = float((accumulate ? double(out[3 * r + c]) : 0.0) + acc[c]);
  }
}

Result<ReducedFeedback> build_reduced_feedback(const Level& level, const Dictionary& dict,
                                               const LevelDependencies& deps, std::span<const float> rho) {
  if (rho.size() != 3 * std::size_t(level.sample_count))
    return Status::error(ErrorCode::invalid_argument,
                         "reduced feedback: albedo has " + std::to_string(rho.size()) + " floats, expected " +
                             std::to_string(3 * std::size_t(level.sample_count)));
  ReducedFeedback op;
  op.kb = level.kb, op.kr = level.kr;
  op.A.reserve(level.blocks.size());
  std::vector<double> acc;
  for (const LevelBlock& blk : level.blocks) {
    const ShapeOperators& shape = dict.shapes[std::size_t(blk.shape)];
    acc.assign(3 * std::size_t(op.kb) * op.kb, 0.0);
    accumulate_weighted_product(shape.Td_b, rho.subspan(3 * std::size_t(blk.sample_offset)), shape.Ub,
                                nullptr, acc);
    op.A.push_back(to_channel_matrix(op.kb, op.kb, acc));
  }
  op.B.reserve(level.slots.size());
  const Matrix& Ur = dict.interfaces.Ur;
  for (const ResponseSlot& slot : level.slots) {
    const LevelBlock& blk = level.blocks[slot.block];
    acc.assign(3 * std::size_t(op.kb) * op.kr, 0.0);
    accumulate_weighted_product(dict.shapes[std::size_t(blk.shape)].Td_b,
                                rho.subspan(3 * std::size_t(blk.sample_offset)), Ur,
                                slot.ur_row_to_sample.data(), acc);
    op.B.push_back(to_channel_matrix(op.kb, op.kr, acc));
  }
  op.spectral_radius = estimate_spectral_radius(level, deps, op);
  if (!std::isfinite(op.spectral_radius))
    return Status::error(ErrorCode::non_finite,
                         "reduced feedback: the spectral radius estimate is not finite (operators overflow)");
  if (op.spectral_radius > kReducedMaxSpectralRadius)
    op.damping = float(kReducedMaxSpectralRadius / op.spectral_radius);
  return op;
}

void reference_apply_reduced_feedback(const Level& level, const LevelDependencies& deps,
                                      const ReducedFeedback& op, std::span<const float> x,
                                      std::span<float> r_scratch, std::span<float> out) {
  const std::size_t bsz = 3 * std::size_t(op.kb), rsz = 3 * std::size_t(op.kr);
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    float* rs = r_scratch.data() + rsz * s;
    std::fill(rs, rs + rsz, 0.0f);
    for (std::uint32_t m : deps.records_of_slot(s)) {
      const ResponseRecord& rec = level.records[m];
      reference_gemv_rgb(rec.T, x.data() + bsz * rec.source_block, rs, true);
    }
  }
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    float* dst = out.data() + bsz * i;
    reference_gemv_channels(op.A[i], x.data() + bsz * i, dst, false);
    for (std::uint32_t s : deps.slots_of_block(i))
      reference_gemv_channels(op.B[s], r_scratch.data() + rsz * s, dst, true);
    if (op.damping != 1.0f)
      for (std::size_t k = 0; k < bsz; ++k) dst[k] *= op.damping;
  }
}

ReducedSolver::Step ReducedSolver::step(std::span<const float> b0, std::span<float> x) {
  Step st;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const float v = b0[i] + next_[i];
    st.change = std::max(st.change, double(std::fabs(v - x[i])));
    st.largest = std::max(st.largest, double(std::fabs(v)));
    x[i] = v;
  }
  return st;
}

Result<ConvergedBounceReport> level_converged_bounce(const Level& level, const Dictionary& dict,
                                                     std::span<const float> ld_direct,
                                                     std::span<const float> albedo,
                                                     const ConvergedBounceSettings& settings,
                                                     std::span<float> b, std::span<float> r,
                                                     std::span<float> lightmap) {
  if (Status s = check_max_albedo(settings.max_albedo, "level_converged_bounce"); !s.ok()) return s;
  if (Status s = validate_light_signal(albedo, level.sample_count, "albedo"); !s.ok()) return s;
  const LevelBufferSizes sizes = level_buffer_sizes(level, dict);
  if (b.size() != sizes.b || r.size() != sizes.r || lightmap.size() != sizes.lightmap)
    return Status::error(ErrorCode::invalid_argument,
                         "level_converged_bounce: b, r or lightmap has the wrong size");
  std::vector<float> rho(albedo.size());
  ConvergedBounceReport report;
  report.albedo_clamped = clamp_albedo(albedo, settings.max_albedo, rho).clamped;
  const LevelDependencies deps = level_dependencies(level);
  Result<ReducedFeedback> op = build_reduced_feedback(level, dict, deps, rho);
  if (!op.ok()) return op.status();
  report.spectral_radius = op->spectral_radius;
  report.damping = op->damping;
  if (Status s = level_compute_b(level, dict, ld_direct, b); !s.ok()) return s;  // validates ld_direct
  const std::vector<float> b0(b.begin(), b.end());
  ReducedSolver solver = ReducedSolver::create(b.size());
  report.solve = solver.solve(
      [&](std::span<const float> x, std::span<float> out) {
        reference_apply_reduced_feedback(level, deps, op.value(), x, r, out);
      },
      b0, b, op->contraction(), settings.solve);
  for (std::size_t s = 0; s < level.slots.size(); ++s) level_compute_slot_r(level, deps, b, s, r);
  for (std::size_t i = 0; i < level.blocks.size(); ++i)
    level_compute_tile(level, dict, deps, b, r, i, lightmap);
  return report;
}

}  // namespace modrt
