// SPDX-License-Identifier: MIT
#include "modrt/reduced_feedback.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "modrt/cube.h"
#include "modrt/drt.h"
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

// The albedo of the samples [first, first + count) of a block when all of them have the same
// one (per channel): the usual case, a level's albedo is per face (level_sample_albedo).
bool constant_albedo(std::span<const float> rho_block, std::size_t first, std::size_t count, float out[3]) {
  for (int c = 0; c < 3; ++c) out[c] = rho_block[3 * first + std::size_t(c)];
  for (std::size_t s = first; s < first + count; ++s)
    for (int c = 0; c < 3; ++c)
      if (rho_block[3 * s + std::size_t(c)] != out[c]) return false;
  return true;
}

// The products a block's A and B are sums of when its albedo is constant per face, computed
// once per shape (and per shape and entry face), single-channel, in double:
//   face[f] = Td_b[:, samples of f] Ub[samples of f, :]   (kb x kb)
//   entry   = Td_b[:, mapped samples] Ur                  (kb x kr, one slot's row map; kept
//                                                         with 3 equal channels, read as one)
// so that A = sum_f rho_f face[f] and B = rho_entry entry cost O(kb^2) per block and slot.
struct ShapeFaceProducts {
  bool ready = false;
  std::array<std::vector<double>, kFaceCount> face;
};
struct EntryProduct {
  std::size_t operator_set = 0;  // operator_set() of the block: its Td_b
  int entry_face = -1;
  const std::vector<std::int32_t>* map = nullptr;  // the row map it was computed for
  std::vector<double> product;
};

void face_products(const ShapeOperators& shape, const SampleLayout& layout, ShapeFaceProducts& out) {
  const std::uint32_t kb = shape.Td_b.rows, per_face = std::uint32_t(layout.texels_per_face());
  for (int f = 0; f < kFaceCount; ++f) {
    if (layout.slot[std::size_t(f)] < 0) continue;
    std::vector<double>& g = out.face[std::size_t(f)];
    g.assign(std::size_t(kb) * kb, 0.0);
    const std::uint32_t first = std::uint32_t(layout.slot[std::size_t(f)]) * per_face;
    for (std::uint32_t k = 0; k < kb; ++k)
      for (std::uint32_t m = first; m < first + per_face; ++m) {
        const double t = shape.Td_b(k, m);
        const float* row = shape.Ub.data.data() + std::size_t(m) * kb;
        for (std::uint32_t j = 0; j < kb; ++j) g[std::size_t(k) * kb + j] += t * row[j];
      }
  }
  out.ready = true;
}

ChannelMatrix to_channel_matrix(std::uint32_t rows, std::uint32_t cols, const std::vector<double>& acc) {
  ChannelMatrix m{rows, cols, std::vector<float>(acc.size())};
  for (std::size_t i = 0; i < acc.size(); ++i) m.data[i] = float(acc[i]);
  return m;
}

ChannelMatrix scaled(const ChannelMatrix& m, float s) {
  ChannelMatrix out = m;
  for (float& v : out.data) v *= s;
  return out;
}

// Power iteration on `apply` (n unknowns, RGB-interleaved): the growth per application of each
// channel's norm over the last iterations, largest over the channels. Deterministic start with
// every entry non-zero.
template <class Apply>
double estimate_spectral_radius(std::size_t n, Apply&& apply) {
  if (n == 0) return 0.0;
  std::vector<float> x(n), y(n);
  std::uint32_t seed = 12345u;
  for (float& v : x) {
    seed = seed * 1664525u + 1013904223u;
    v = 0.5f + float(seed >> 8) / float(1u << 24);
  }
  constexpr int kWarmup = 16, kMeasured = 8;
  double log_growth[3] = {0.0, 0.0, 0.0};
  for (int it = 0; it < kWarmup + kMeasured; ++it) {
    apply(x, y);
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

// (I - s A)^-1 per channel by Gauss-Jordan with partial pivoting in double; false when a pivot
// is below 1e-12 (I - s A singular: block Jacobi is not available).
bool invert_identity_minus(const ChannelMatrix& A, float s, ChannelMatrix& out) {
  const std::size_t n = A.rows;
  out = ChannelMatrix{A.rows, A.cols, std::vector<float>(A.data.size())};
  std::vector<double> m(n * n), inv(n * n);
  for (int c = 0; c < 3; ++c) {
    for (std::size_t r = 0; r < n; ++r)
      for (std::size_t k = 0; k < n; ++k) {
        m[r * n + k] = (r == k ? 1.0 : 0.0) - double(s) * A.data[3 * (r * n + k) + std::size_t(c)];
        inv[r * n + k] = r == k ? 1.0 : 0.0;
      }
    for (std::size_t col = 0; col < n; ++col) {
      std::size_t pivot = col;
      for (std::size_t r = col + 1; r < n; ++r)
        if (std::fabs(m[r * n + col]) > std::fabs(m[pivot * n + col])) pivot = r;
      if (!(std::fabs(m[pivot * n + col]) >= 1e-12)) return false;
      if (pivot != col)
        for (std::size_t k = 0; k < n; ++k)
          std::swap(m[col * n + k], m[pivot * n + k]), std::swap(inv[col * n + k], inv[pivot * n + k]);
      const double d = 1.0 / m[col * n + col];
      for (std::size_t k = 0; k < n; ++k) m[col * n + k] *= d, inv[col * n + k] *= d;
      for (std::size_t r = 0; r < n; ++r) {
        if (r == col) continue;
        const double f = m[r * n + col];
        if (f == 0.0) continue;
        for (std::size_t k = 0; k < n; ++k)
          m[r * n + k] -= f * m[col * n + k], inv[r * n + k] -= f * inv[col * n + k];
      }
    }
    for (std::size_t i = 0; i < n * n; ++i) out.data[3 * i + std::size_t(c)] = float(inv[i]);
  }
  return true;
}

// left (n x n per channel) times s right (n x m per channel), in double.
ChannelMatrix channel_product(const ChannelMatrix& left, const ChannelMatrix& right, float s) {
  const std::size_t n = left.rows, inner = left.cols, m = right.cols;
  std::vector<double> acc(3 * n * m, 0.0);
  for (std::size_t r = 0; r < n; ++r)
    for (std::size_t k = 0; k < inner; ++k)
      for (int c = 0; c < 3; ++c) {
        const double l = double(left.data[3 * (r * inner + k) + std::size_t(c)]) * s;
        if (l == 0.0) continue;
        for (std::size_t j = 0; j < m; ++j)
          acc[3 * (r * m + j) + std::size_t(c)] += l * right.data[3 * (k * m + j) + std::size_t(c)];
      }
  return to_channel_matrix(left.rows, right.cols, acc);
}

// The clutter's part of the reduced feedback (ReducedClutter): the samples its deltas reach,
// their blocks, and Td_b's column of each times its albedo.
ReducedClutter build_reduced_clutter(const Level& level, const Dictionary& dict, std::span<const float> rho,
                                     const DrtOperators& drt, std::span<const float> rho_c) {
  ReducedClutter cl;
  cl.drt = &drt;
  cl.c_unknowns = drt_buffer_sizes(drt).c;
  cl.rho_c.assign(rho_c.begin(), rho_c.end());
  std::vector<std::uint8_t> reached(level.sample_count, 0);
  for (const DrtObjectOperators& o : drt.objects) {
    for (std::uint32_t s : o.dUb_sample) reached[s] = 1;
    for (std::uint32_t s : o.dUc_sample) reached[s] = 1;
  }
  cl.position.assign(level.sample_count, -1);
  const std::size_t kb = level.kb;
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const LevelBlock& blk = level.blocks[i];
    const Matrix& Td = block_operators(dict, level, blk).Td_b;
    for (std::uint32_t local = 0; local < blk.sample_count; ++local) {
      const std::uint32_t s = blk.sample_offset + local;
      if (!reached[s]) continue;
      cl.position[s] = std::int32_t(cl.samples.size());
      cl.samples.push_back(s);
      cl.sample_block.push_back(std::uint32_t(i));
      for (std::size_t k = 0; k < kb; ++k)  // level.kb wide, zero past the block's modes
        for (std::size_t ch = 0; ch < 3; ++ch)
          cl.w.push_back(k < Td.rows ? Td(std::uint32_t(k), local) * rho[3 * std::size_t(s) + ch] : 0.0f);
    }
  }
  return cl;
}

}  // namespace

void ReducedClutterScratch::allocate(const Level& level, std::uint32_t kb, const DrtOperators& drt) {
  const DrtBufferSizes d = drt_buffer_sizes(drt);
  delta.assign(3 * std::size_t(level.sample_count), 0.0f);
  indirect.assign(d.clutter_lightmap, 0.0f);
  t.assign(3 * std::size_t(kb) * (level.blocks.size() + 1), 0.0f);
}

void reduced_clutter_clear(const ReducedFeedback& op, ReducedClutterScratch& scratch) {
  for (std::uint32_t s : op.clutter.samples)
    for (std::size_t ch = 0; ch < 3; ++ch) scratch.delta[3 * std::size_t(s) + ch] = 0.0f;
}

void reduced_clutter_start(const ReducedFeedback& op, std::size_t nb, std::span<const float> c0,
                           std::span<float> x, std::span<float> rhs, bool warm) {
  if (!op.clutter.drt) return;
  std::copy(c0.begin(), c0.end(), rhs.begin() + std::ptrdiff_t(nb));
  if (!warm) std::copy(c0.begin(), c0.end(), x.begin() + std::ptrdiff_t(nb));
}

void reduced_clutter_feedback(const Level& level, const ReducedFeedback& op, ReducedClutterScratch& scratch,
                              std::span<float> out) {
  const ReducedClutter& cl = op.clutter;
  const DrtOperators& drt = *cl.drt;
  const std::size_t bsz = 3 * std::size_t(op.kb), nb = bsz * level.blocks.size();
  const float s = cl.scale;
  // b: per block, t = s sum over its reached samples of w delta, then out += P t (or t).
  float* t = scratch.t.data();
  float* pt = scratch.t.data() + nb;  // P t
  for (std::size_t first = 0; first < cl.samples.size();) {
    const std::uint32_t blk = cl.sample_block[first];
    std::fill(t, t + bsz, 0.0f);
    std::size_t p = first;
    for (; p < cl.samples.size() && cl.sample_block[p] == blk; ++p) {
      const float* w = cl.w.data() + bsz * p;
      const float* d = scratch.delta.data() + 3 * std::size_t(cl.samples[p]);
      for (std::size_t k = 0; k < op.kb; ++k)
        for (std::size_t ch = 0; ch < 3; ++ch) t[3 * k + ch] += w[3 * k + ch] * d[ch];
    }
    for (std::size_t e = 0; e < bsz; ++e) t[e] *= s;
    float* dst = out.data() + bsz * blk;
    if (op.P.empty()) {
      for (std::size_t e = 0; e < bsz; ++e) dst[e] += t[e];
    } else {
      reference_gemv_channels(op.P[blk], t, pt, false);
      for (std::size_t e = 0; e < 3 * std::size_t(op.P[blk].rows); ++e) dst[e] += pt[e];
    }
    first = p;
  }
  // c = s Td_c diag(rho_c) (Cb b + Cc c) per object (zero when the clutter's light is not fed back).
  float* oc = out.data() + nb;
  std::fill(oc, oc + cl.c_unknowns, 0.0f);
  if (cl.rho_c.empty()) return;
  std::size_t texel0 = 0, face0 = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    for (std::uint32_t j = 0; j < o.face_count; ++j) {
      double acc[3] = {0.0, 0.0, 0.0};
      for (std::uint32_t m = 0; m < o.texel_count; ++m) {
        const double tdc = o.Td_c(j, m);
        if (tdc == 0.0) continue;
        const std::size_t e = 3 * (texel0 + m);
        for (std::size_t ch = 0; ch < 3; ++ch)
          acc[ch] += tdc * double(cl.rho_c[e + ch]) * double(scratch.indirect[e + ch]);
      }
      for (std::size_t ch = 0; ch < 3; ++ch) oc[3 * (face0 + j) + ch] = float(double(s) * acc[ch]);
    }
    texel0 += o.texel_count, face0 += o.face_count;
  }
}

void reference_apply_reduced_clutter(const Level& level, const ReducedFeedback& op, std::span<const float> x,
                                     std::span<float> out, ReducedClutterScratch& scratch) {
  const DrtOperators& drt = *op.clutter.drt;
  const std::size_t nb = 3 * std::size_t(op.kb) * level.blocks.size();
  const std::span<const float> b = x.first(nb), c = x.subspan(nb, op.clutter.c_unknowns);
  reduced_clutter_clear(op, scratch);
  drt_apply(level, drt, b, c, scratch.delta);
  if (!op.clutter.rho_c.empty()) {
    drt_clutter_lightmap(drt, b, {}, scratch.indirect);
    drt_clutter_add_cc(drt, c, scratch.indirect);
  }
  reduced_clutter_feedback(level, op, scratch, out);
}

void reference_gemv_channels(const ChannelMatrix& M, const float* in, float* out, bool accumulate) {
  for (std::uint32_t r = 0; r < M.rows; ++r) {
    const float* row = M.data.data() + 3 * std::size_t(r) * M.cols;
    double acc[3] = {0.0, 0.0, 0.0};
    for (std::uint32_t k = 0; k < M.cols; ++k)
      for (int c = 0; c < 3; ++c) acc[c] += double(row[3 * k + c]) * in[3 * k + c];
    for (int c = 0; c < 3; ++c) out[3 * r + c] = float((accumulate ? double(out[3 * r + c]) : 0.0) + acc[c]);
  }
}

const DrtOperators* reduced_solve_clutter(const DrtOperators* drt) {
  return drt && !drt->has_gather() ? drt : nullptr;
}

Result<ReducedFeedback> build_reduced_feedback(const Level& level, const Dictionary& dict,
                                               const LevelDependencies& deps, std::span<const float> rho,
                                               const ReducedApply& apply, const DrtOperators* drt,
                                               std::span<const float> rho_c) {
  if (rho.size() != 3 * std::size_t(level.sample_count))
    return Status::error(ErrorCode::invalid_argument,
                         "reduced feedback: albedo has " + std::to_string(rho.size()) + " floats, expected " +
                             std::to_string(3 * std::size_t(level.sample_count)));
  // The gather's terms read ld and the clutter's light directly, not through b and c.
  if (drt && reduced_solve_clutter(drt) != drt)
    return Status::error(
        ErrorCode::invalid_argument,
        "reduced feedback: the clutter operators gather the real radiance (DrtObjectOperators::Gs, "
        "Hs), which the reduced solve in b and c cannot express (reduced_solve_clutter)");
  // M itself: A = Td_b diag(rho) Ub per block, B = Td_b diag(rho) Ur turned per slot.
  ReducedFeedback plain;
  plain.kb = level.kb, plain.kr = level.kr, plain.block_jacobi = false;
  plain.A.reserve(level.blocks.size());
  std::vector<double> acc;
  std::vector<ShapeFaceProducts> shape_products(operator_set_count(dict, level));
  for (const LevelBlock& blk : level.blocks) {
    const ShapeOperators& shape = block_operators(dict, level, blk);
    const std::uint32_t kb = shape.Td_b.rows;  // the block's modes (block_kb)
    const std::size_t kb2 = std::size_t(kb) * kb;
    const std::span<const float> rho_block = rho.subspan(3 * std::size_t(blk.sample_offset));
    const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(blk.shape), level.res);
    const std::size_t per_face = std::size_t(layout.texels_per_face());
    float face_rho[kFaceCount][3] = {};
    bool per_face_constant = true;
    for (int f = 0; f < kFaceCount && per_face_constant; ++f)
      if (layout.slot[std::size_t(f)] >= 0)
        per_face_constant = constant_albedo(rho_block, std::size_t(layout.slot[std::size_t(f)]) * per_face,
                                            per_face, face_rho[f]);
    acc.assign(3 * kb2, 0.0);
    if (per_face_constant) {  // A = sum_f rho_f face[f]
      ShapeFaceProducts& fp = shape_products[operator_set(dict, blk)];
      if (!fp.ready) face_products(shape, layout, fp);
      for (int f = 0; f < kFaceCount; ++f) {
        if (layout.slot[std::size_t(f)] < 0) continue;
        const std::vector<double>& g = fp.face[std::size_t(f)];
        for (std::size_t e = 0; e < kb2; ++e)
          for (int c = 0; c < 3; ++c) acc[3 * e + std::size_t(c)] += double(face_rho[f][c]) * g[e];
      }
    } else {
      accumulate_weighted_product(shape.Td_b, rho_block, shape.Ub, nullptr, acc);
    }
    plain.A.push_back(to_channel_matrix(kb, kb, acc));
  }
  plain.B.reserve(level.slots.size());
  const Matrix& Ur = dict.interfaces.Ur;
  std::vector<EntryProduct> entry_products;
  std::vector<float> ones;
  for (const ResponseSlot& slot : level.slots) {
    const LevelBlock& blk = level.blocks[slot.block];
    const Matrix& Td = block_operators(dict, level, blk).Td_b;
    const std::size_t kbr = std::size_t(Td.rows) * plain.kr;
    const std::span<const float> rho_block = rho.subspan(3 * std::size_t(blk.sample_offset));
    // The mapped samples all lie on the entry face: one albedo when that face's is constant.
    float entry_rho[3] = {0.0f, 0.0f, 0.0f};
    bool constant = true, first = true;
    for (std::int32_t sample : slot.ur_row_to_sample) {
      if (sample < 0) continue;
      float v[3];
      constant_albedo(rho_block, std::size_t(sample), 1, v);
      if (first) {
        std::copy(v, v + 3, entry_rho), first = false;
      } else if (v[0] != entry_rho[0] || v[1] != entry_rho[1] || v[2] != entry_rho[2]) {
        constant = false;
        break;
      }
    }
    acc.assign(3 * kbr, 0.0);
    if (constant) {  // B = rho_entry entry
      EntryProduct* ep = nullptr;
      for (EntryProduct& e : entry_products)
        if (e.operator_set == operator_set(dict, blk) && e.entry_face == slot.entry_face &&
            *e.map == slot.ur_row_to_sample)
          ep = &e;
      if (!ep) {
        EntryProduct e{operator_set(dict, blk), slot.entry_face, &slot.ur_row_to_sample,
                       std::vector<double>(3 * kbr, 0.0)};
        ones.assign(3 * std::size_t(blk.sample_count), 1.0f);
        accumulate_weighted_product(Td, ones, Ur, slot.ur_row_to_sample.data(), e.product);
        entry_products.push_back(std::move(e));
        ep = &entry_products.back();
      }
      for (std::size_t e = 0; e < kbr; ++e)
        for (int c = 0; c < 3; ++c) acc[3 * e + std::size_t(c)] = double(entry_rho[c]) * ep->product[3 * e];
    } else {
      accumulate_weighted_product(Td, rho_block, Ur, slot.ur_row_to_sample.data(), acc);
    }
    plain.B.push_back(to_channel_matrix(Td.rows, plain.kr, acc));
  }
  if (drt && !drt->empty()) plain.clutter = build_reduced_clutter(level, dict, rho, *drt, rho_c);
  const std::size_t n = plain.unknowns(level);
  std::vector<float> r(3 * std::size_t(plain.kr) * level.slots.size());
  ReducedClutterScratch clutter_scratch;
  if (plain.clutter.drt) clutter_scratch.allocate(level, plain.kb, *plain.clutter.drt);
  const auto radius = [&](const ReducedFeedback& op) {
    return estimate_spectral_radius(n, [&](std::span<const float> x, std::span<float> y) {
      if (apply)
        apply(op, x, y);
      else
        reference_apply_reduced_feedback(level, deps, op, x, r, y);
      if (op.clutter.drt) reference_apply_reduced_clutter(level, op, x, y, clutter_scratch);
    });
  };
  const double q = radius(plain);
  if (!std::isfinite(q))
    return Status::error(ErrorCode::non_finite,
                         "reduced feedback: the spectral radius estimate is not finite (operators overflow)");
  const float s = q > kReducedMaxSpectralRadius ? float(kReducedMaxSpectralRadius / q) : 1.0f;
  // Block Jacobi: P_i = (I - s A_i)^-1, B_s = P_i s B_s.
  ReducedFeedback bj;
  bj.kb = plain.kb, bj.kr = plain.kr, bj.block_jacobi = true;
  bj.clutter = plain.clutter;
  bj.clutter.scale = s;
  bool invertible = true;
  bj.P.resize(level.blocks.size());
  for (std::size_t i = 0; i < level.blocks.size() && invertible; ++i)
    invertible = invert_identity_minus(plain.A[i], s, bj.P[i]);
  double q_bj = 0.0;
  if (invertible) {
    bj.B.reserve(level.slots.size());
    for (std::size_t sl = 0; sl < level.slots.size(); ++sl)
      bj.B.push_back(channel_product(bj.P[level.slots[sl].block], plain.B[sl], s));
    q_bj = radius(bj);
  }
  const double q_plain = double(s) * q;
  ReducedFeedback out;
  if (invertible && std::isfinite(q_bj) && q_bj < kReducedMaxSpectralRadius && q_bj < q_plain) {
    out = std::move(bj);
    out.contraction = q_bj;
  } else {
    out = std::move(plain);
    for (ChannelMatrix& m : out.A) m = scaled(m, s);
    for (ChannelMatrix& m : out.B) m = scaled(m, s);
    out.clutter.scale = s;
    out.contraction = q_plain;
  }
  out.spectral_radius = q;
  out.damping = s;
  return out;
}

void reference_reduced_rhs(const Level& level, const ReducedFeedback& op, std::span<const float> b0,
                           std::span<float> c) {
  if (op.P.empty()) {
    std::copy(b0.begin(), b0.end(), c.begin());
    return;
  }
  const std::size_t bsz = 3 * std::size_t(op.kb);
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    float* ci = c.data() + bsz * i;
    reference_gemv_channels(op.P[i], b0.data() + bsz * i, ci, false);
    std::fill(ci + 3 * std::size_t(op.P[i].rows), ci + bsz, 0.0f);  // past the block's modes
  }
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
    std::fill(dst, dst + bsz, 0.0f);  // zero past the block's modes too
    if (!op.A.empty()) reference_gemv_channels(op.A[i], x.data() + bsz * i, dst, false);
    for (std::uint32_t s : deps.slots_of_block(i))
      reference_gemv_channels(op.B[s], r_scratch.data() + rsz * s, dst, true);
  }
}

void reference_apply_reduced_feedback_delta(const Level& level, const LevelDependencies& deps,
                                            const ReducedFeedback& op, std::span<const float> delta,
                                            std::span<const std::uint8_t> blocks, std::span<float> y,
                                            std::span<float> r, std::span<float> r_delta) {
  const std::size_t bsz = 3 * std::size_t(op.kb), rsz = 3 * std::size_t(op.kr);
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    float* rs = r_delta.data() + rsz * s;
    std::fill(rs, rs + rsz, 0.0f);
    for (std::uint32_t m : deps.records_of_slot(s)) {
      const ResponseRecord& rec = level.records[m];
      if (blocks[rec.source_block])
        reference_gemv_rgb(rec.T, delta.data() + bsz * rec.source_block, rs, true);
    }
    float* acc = r.data() + rsz * s;
    for (std::size_t k = 0; k < rsz; ++k) acc[k] += rs[k];
  }
  std::vector<float> gd(bsz);  // the scalar reference allocates
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    std::fill(gd.begin(), gd.end(), 0.0f);
    if (!op.A.empty() && blocks[i])
      reference_gemv_channels(op.A[i], delta.data() + bsz * i, gd.data(), false);
    for (std::uint32_t s : deps.slots_of_block(i))
      reference_gemv_channels(op.B[s], r_delta.data() + rsz * s, gd.data(), true);
    float* dst = y.data() + bsz * i;
    for (std::size_t k = 0; k < bsz; ++k) dst[k] += gd[k];
  }
}

int reduced_solve_iterations(double contraction, float tolerance, int max_iterations) {
  const int cap = std::max(max_iterations, 1);
  if (!(contraction > 1e-12)) return 1;
  if (!(contraction < 1.0) || !(tolerance > 0.0f)) return cap;
  const double k = std::ceil(std::log(double(tolerance)) / std::log(contraction));
  return k < 1.0 ? 1 : (k > double(cap) ? cap : int(k));
}

bool ReducedSolver::history_coefficients(std::size_t c, int k_max, double* a) const {
  const std::size_t n = rhs_.size();
  double g[kMaxHistory][kMaxHistory] = {}, h[kMaxHistory] = {};
  for (int p = 0; p < k_max; ++p) {
    const float* rp = history_rhs_.data() + history_slot(p, n);
    for (std::size_t i = c; i < n; i += 3) h[p] += double(rp[i]) * rhs_[i];
    for (int q = 0; q <= p; ++q) {
      const float* rq = history_rhs_.data() + history_slot(q, n);
      double d = 0.0;
      for (std::size_t i = c; i < n; i += 3) d += double(rp[i]) * rq[i];
      g[p][q] = g[q][p] = d;
    }
  }
  double trace = 0.0;
  for (int p = 0; p < k_max; ++p) trace += g[p][p];
  if (!(trace > 0.0)) return false;  // this channel has no light: nothing to predict
  for (int p = 0; p < k_max; ++p) g[p][p] += 1e-9 * trace;
  // Gaussian elimination with partial pivoting on [g | h].
  const int k = k_max;
  for (int col = 0; col < k; ++col) {
    int pivot = col;
    for (int r = col + 1; r < k; ++r)
      if (std::fabs(g[r][col]) > std::fabs(g[pivot][col])) pivot = r;
    if (!(std::fabs(g[pivot][col]) > 1e-300)) return false;
    if (pivot != col) {
      for (int j = 0; j < k; ++j) std::swap(g[col][j], g[pivot][j]);
      std::swap(h[col], h[pivot]);
    }
    for (int r = col + 1; r < k; ++r) {
      const double f = g[r][col] / g[col][col];
      for (int j = col; j < k; ++j) g[r][j] -= f * g[col][j];
      h[r] -= f * h[col];
    }
  }
  for (int r = k - 1; r >= 0; --r) {
    double v = h[r];
    for (int j = r + 1; j < k; ++j) v -= g[r][j] * a[j];
    a[r] = v / g[r][r];
    if (!std::isfinite(a[r])) return false;
  }
  return true;
}

void ReducedSolver::predict(std::span<float> x, bool warm, int history) {
  const std::size_t n = rhs_.size();
  if (!warm) {
    count_ = 0;  // another operator: its solutions do not apply
    return;
  }
  if (count_ == 0) return;
  const int k_max = std::min(count_, std::max(history, 1));
  if (history <= 0) {  // the last solution moved by the change of rhs
    const float* r_last = history_rhs_.data() + history_slot(0, n);
    for (std::size_t i = 0; i < n; ++i) x[i] += rhs_[i] - r_last[i];
    return;
  }
  // Per channel: x = sum_k a_k x_k + (rhs - sum_k a_k rhs_k).
  for (std::size_t c = 0; c < 3; ++c) {
    double a[kMaxHistory] = {};
    if (!history_coefficients(c, k_max, a)) continue;  // x stays the last solution for this channel
    for (std::size_t i = c; i < n; i += 3) {
      double v = rhs_[i];
      for (int p = 0; p < k_max; ++p) {
        const std::size_t o = history_slot(p, n) + i;
        v += a[p] * (double(history_x_[o]) - double(history_rhs_[o]));
      }
      x[i] = float(v);
    }
  }
}

void ReducedSolver::predict_state(int history) {
  if (count_ == 0) return;
  const std::size_t n = rhs_.size(), nr = r_.size();
  const int k_max = std::min(count_, std::max(history, 1));
  const auto combine = [&](const double* a, std::size_t c, std::size_t size, const std::vector<float>& ring,
                           std::vector<float>& out) {
    for (std::size_t i = c; i < size; i += 3) {
      double v = 0.0;
      for (int p = 0; p < k_max; ++p) v += a[p] * double(ring[history_slot(p, size) + i]);
      out[i] = float(v);
    }
  };
  for (std::size_t c = 0; c < 3; ++c) {
    double a[kMaxHistory] = {};
    if (!history_coefficients(c, k_max, a)) continue;  // the state stays the last solve's
    combine(a, c, n, history_x_, applied_);
    combine(a, c, n, history_y_, next_);
    combine(a, c, nr, history_r_, r_);
  }
}

void ReducedSolver::remember_state() {
  const std::size_t n = rhs_.size(), nr = r_.size(), o = std::size_t(head_) * n;
  std::copy(rhs_.begin(), rhs_.end(), history_rhs_.begin() + std::ptrdiff_t(o));
  std::copy(applied_.begin(), applied_.end(), history_x_.begin() + std::ptrdiff_t(o));
  std::copy(next_.begin(), next_.end(), history_y_.begin() + std::ptrdiff_t(o));
  std::copy(r_.begin(), r_.end(), history_r_.begin() + std::ptrdiff_t(std::size_t(head_) * nr));
  head_ = (head_ + 1) % capacity_;
  count_ = std::min(count_ + 1, capacity_);
}

void ReducedSolver::remember(std::span<const float> x) {
  const std::size_t n = rhs_.size(), o = std::size_t(head_) * n;
  std::copy(rhs_.begin(), rhs_.end(), history_rhs_.begin() + std::ptrdiff_t(o));
  std::copy(x.begin(), x.begin() + std::ptrdiff_t(n), history_x_.begin() + std::ptrdiff_t(o));
  head_ = (head_ + 1) % capacity_;
  count_ = std::min(count_ + 1, capacity_);
}

ReducedSolver::Step ReducedSolver::step(std::span<float> x) {
  Step st;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const float v = rhs_[i] + next_[i];
    st.change = std::max(st.change, double(std::fabs(v - x[i])));
    st.largest = std::max(st.largest, double(std::fabs(v)));
    x[i] = v;
  }
  return st;
}

ReducedSolver::Step ReducedSolver::incremental_step(std::span<float> x) {
  Step st;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const float v = rhs_[i] + next_[i];
    const float d = v - applied_[i];
    st.change = std::max(st.change, double(std::fabs(d)));
    st.largest = std::max(st.largest, double(std::fabs(v)));
    x[i] = v;
    delta_[i] = d;
  }
  return st;
}

std::size_t ReducedSolver::flag_changed(double threshold) {
  const std::size_t n = delta_.size();
  std::size_t count = 0;
  for (std::size_t k = 0; k < flags_.size(); ++k) {
    const std::size_t first = k * block_floats_, last = std::min(n, first + block_floats_);
    double change = 0.0;
    for (std::size_t i = first; i < last; ++i) change = std::max(change, double(std::fabs(delta_[i])));
    flags_[k] = change > threshold ? 1 : 0;
    count += flags_[k];
  }
  return count;
}

void ReducedSolver::take_flagged(std::span<const float> x) {
  const std::size_t n = applied_.size();
  for (std::size_t k = 0; k < flags_.size(); ++k)
    if (flags_[k])
      for (std::size_t i = k * block_floats_, last = std::min(n, i + block_floats_); i < last; ++i)
        applied_[i] = x[i];
}

namespace {

// level_converged_bounce and, with drt, drt_converged_bounce: validate, clamp the albedos, build
// the reduced feedback, solve from x = (b0, c0) and write b*, c*, r and the lightmap from them.
Result<ConvergedBounceReport> converged_bounce(
    const char* who, const Level& level, const Dictionary& dict, const DrtOperators* drt,
    std::span<const float> ld_direct, std::span<const float> albedo, std::span<const float> clutter_ld,
    std::span<const float> clutter_albedo, const ConvergedBounceSettings& settings, std::span<float> b,
    std::span<float> r, std::span<float> lightmap, std::span<float> c, std::span<float> last_ld,
    std::span<float> last_clutter_radiance) {
  if (Status s = check_max_albedo(settings.max_albedo, who); !s.ok()) return s;
  if (Status s = validate_light_signal(albedo, level.sample_count, "albedo"); !s.ok()) return s;
  if (drt) {
    const DrtBufferSizes dsz = drt_buffer_sizes(*drt);
    if (c.size() != dsz.c)
      return Status::error(ErrorCode::invalid_argument, std::string(who) + ": c: wrong size");
    if (!clutter_albedo.empty())
      if (Status s = validate_light_signal(clutter_albedo, dsz.clutter_texels, "clutter_albedo"); !s.ok())
        return s;
  }
  const LevelBufferSizes sizes = level_buffer_sizes(level, dict);
  if (b.size() != sizes.b || r.size() != sizes.r || lightmap.size() != sizes.lightmap)
    return Status::error(ErrorCode::invalid_argument,
                         std::string(who) + ": b, r or lightmap has the wrong size");
  std::vector<float> rho(albedo.size()), rho_c(clutter_albedo.size());
  ConvergedBounceReport report;
  report.albedo_clamped = clamp_albedo(albedo, settings.max_albedo, rho).clamped;
  if (!rho_c.empty())
    report.albedo_clamped |= clamp_albedo(clutter_albedo, settings.max_albedo, rho_c).clamped;
  const LevelDependencies deps = level_dependencies(level);
  Result<ReducedFeedback> op =
      build_reduced_feedback(level, dict, deps, rho, {}, reduced_solve_clutter(drt), rho_c);
  if (!op.ok()) return op.status();
  report.spectral_radius = op->spectral_radius;
  report.damping = op->damping;
  report.contraction = op->contraction;
  report.block_jacobi = op->block_jacobi;
  if (Status s = level_compute_b(level, dict, ld_direct, b); !s.ok()) return s;  // validates ld_direct
  if (drt)
    if (Status s = drt_compute_c(*drt, clutter_ld, c); !s.ok()) return s;  // c0, validates clutter_ld
  const bool with_clutter = op->clutter.drt != nullptr;
  const std::size_t nb = b.size();
  ReducedSolver solver = ReducedSolver::create(op->unknowns(level));
  std::vector<float> x(solver.unknowns());
  reference_reduced_rhs(level, op.value(), b, solver.rhs().first(nb));
  std::copy(b.begin(), b.end(), x.begin());
  reduced_clutter_start(op.value(), nb, c, x, solver.rhs(), false);
  ReducedClutterScratch scratch;
  if (with_clutter) scratch.allocate(level, op->kb, *drt);
  report.solve = solver.solve(
      [&](std::span<const float> in, std::span<float> out) {
        reference_apply_reduced_feedback(level, deps, op.value(), in, r, out);
        if (with_clutter) reference_apply_reduced_clutter(level, op.value(), in, out, scratch);
      },
      x, op->contraction, settings.solve);
  std::copy(x.begin(), x.begin() + std::ptrdiff_t(nb), b.begin());
  if (with_clutter) std::copy(x.begin() + std::ptrdiff_t(nb), x.end(), c.begin());
  // r: the last application's (Tb->r of the iterate before b*), as every backend's.
  for (std::size_t i = 0; i < level.blocks.size(); ++i)
    level_compute_tile(level, dict, deps, b, r, i, lightmap);
  if (drt) {
    drt_apply(level, *drt, b, c, lightmap);
    drt_apply_gather(*drt, ld_direct, clutter_ld, lightmap);
    clamp_lightmap(lightmap);
  }
  if (!last_ld.empty()) std::copy(ld_direct.begin(), ld_direct.end(), last_ld.begin());
  if (!last_clutter_radiance.empty())
    std::copy(clutter_ld.begin(), clutter_ld.end(), last_clutter_radiance.begin());
  if (drt && !with_clutter && drt->has_gather()) {  // the steps with the clutter (drt.h)
    MultiBounceSettings steps;
    steps.max_iterations = kGatherConvergedSteps;
    steps.tolerance = 0.0f;
    steps.max_albedo = settings.max_albedo;
    Result<MultiBounceReport> fed =
        drt_multi_bounce(level, dict, *drt, ld_direct, albedo, clutter_ld, clutter_albedo, steps, b, r,
                         lightmap, c, last_ld, last_clutter_radiance, true);
    if (!fed.ok()) return fed.status();
  }
  return report;
}

}  // namespace

Result<ConvergedBounceReport> level_converged_bounce(const Level& level, const Dictionary& dict,
                                                     std::span<const float> ld_direct,
                                                     std::span<const float> albedo,
                                                     const ConvergedBounceSettings& settings,
                                                     std::span<float> b, std::span<float> r,
                                                     std::span<float> lightmap) {
  return converged_bounce("level_converged_bounce", level, dict, nullptr, ld_direct, albedo, {}, {}, settings,
                          b, r, lightmap, {}, {}, {});
}

Result<ConvergedBounceReport> drt_converged_bounce(
    const Level& level, const Dictionary& dict, const DrtOperators& drt, std::span<const float> ld_direct,
    std::span<const float> albedo, std::span<const float> clutter_ld, std::span<const float> clutter_albedo,
    const ConvergedBounceSettings& settings, std::span<float> b, std::span<float> r,
    std::span<float> lightmap, std::span<float> c, std::span<float> last_ld,
    std::span<float> last_clutter_radiance) {
  return converged_bounce("drt_converged_bounce", level, dict, &drt, ld_direct, albedo, clutter_ld,
                          clutter_albedo, settings, b, r, lightmap, c, last_ld, last_clutter_radiance);
}

}  // namespace modrt
