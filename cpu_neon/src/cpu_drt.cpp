// SPDX-License-Identifier: MIT
#include "modrt/cpu/cpu_drt.h"

#include <algorithm>
#include <cstring>
#include <map>
#include <string>

#include "modrt/cpu/kernels.h"
#include "modrt/reference_runtime.h"

namespace modrt::cpu {
namespace {

Status wrong_size(const char* what, std::size_t got, std::size_t expected) {
  return Status::error(ErrorCode::invalid_argument, std::string("cpu drt: ") + what + ": has " +
                                                        std::to_string(got) + " floats, expected " +
                                                        std::to_string(expected));
}

// One delta's operators in an object (drt.h): the b part, W rows per (item, block) entry,
// and the face part, W rows per item over the object's f faces.
struct DeltaOperators {
  const std::vector<std::uint32_t>* b_item;
  const std::vector<std::uint32_t>* b_block;
  const Matrix* b;
  const std::vector<std::uint32_t>* c_item;
  const Matrix* c;
};

}  // namespace

CpuDrtRuntime::Delta CpuDrtRuntime::build_delta(const DrtOperators& drt, std::uint32_t kb, DeltaKind kind,
                                                const std::vector<std::size_t>& face0) {
  const std::uint32_t W = kind == DeltaKind::lightmap ? 1 : kind == DeltaKind::vector ? 4 : 9;
  auto parts = [kind](const DrtObjectOperators& o) -> DeltaOperators {
    if (kind == DeltaKind::lightmap) return {&o.dUb_sample, &o.dUb_block, &o.dUb, &o.dUc_sample, &o.dUc};
    if (kind == DeltaKind::vector)  // DRT §5, the OHLSH vector irradiance
      return {&o.dUb_vec_sample, &o.dUb_vec_block, &o.dUb_vec, &o.dUc_vec_sample, &o.dUc_vec};
    return {&o.Udyn_probe, &o.Udyn_block, &o.Udyn, &o.Udyn_c_probe, &o.Udyn_c};  // DRT §5, U_dyn
  };
  Delta d;
  // b part (DRT §4.1): the rows of every object for one (block, item) read the same b, so
  // they are summed into one entry. The map's order is the groups' (by block) and, within a
  // group, ascending items, so the scatter walks the output forward.
  const std::size_t per_entry = std::size_t(W) * kb;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::size_t> entry;
  std::vector<double> sum;
  for (const DrtObjectOperators& o : drt.objects) {
    const DeltaOperators op = parts(o);
    for (std::size_t e = 0; e < op.b_item->size(); ++e) {
      const auto [it, added] = entry.try_emplace({(*op.b_block)[e], (*op.b_item)[e]}, sum.size() / per_entry);
      if (added) sum.resize(sum.size() + per_entry, 0.0);
      // Rows W e .. W e + W - 1 (kb columns each) are contiguous.
      const float* src = op.b->data.data() + e * per_entry;
      double* dst = sum.data() + it->second * per_entry;
      for (std::size_t k = 0; k < per_entry; ++k) dst[k] += double(src[k]);
    }
  }
  for (auto it = entry.begin(); it != entry.end();) {
    const std::uint32_t block = it->first.first;
    std::size_t n = 0;
    for (auto e = it; e != entry.end() && e->first.first == block; ++e) ++n;
    BlockGroup g;
    g.block = block;
    g.rows = Matrix(std::uint32_t(W * n), kb);
    g.slot.reserve(W * n);
    for (std::size_t i = 0; i < n; ++i, ++it) {
      const double* src = sum.data() + it->second * per_entry;
      std::transform(src, src + per_entry, g.rows.data.begin() + std::ptrdiff_t(i * per_entry),
                     [](double v) { return float(v); });
      for (std::uint32_t w = 0; w < W; ++w) g.slot.push_back(std::int32_t(W * it->first.second + w));
    }
    d.shape.b_rows += g.rows.rows;
    d.b.push_back(std::move(g));
  }
  d.shape.b_groups = d.b.size();

  // Face part (DRT §4.2): an item's rows multiply different objects' c, so they cannot be
  // summed; they are concatenated over the window of c spanning those objects' faces (one
  // GEMV row and one scatter instead of one per object), unless the window would hold more
  // than twice their faces (objects far apart in the list): zeros would then cost more than
  // the separate rows.
  struct FaceRow {
    std::size_t object, entry;
  };
  std::map<std::uint32_t, std::vector<FaceRow>> by_item;  // objects ascending within an item
  for (std::size_t i = 0; i < drt.objects.size(); ++i) {
    const DeltaOperators op = parts(drt.objects[i]);
    if (drt.objects[i].face_count == 0) continue;  // no columns: adds nothing
    for (std::size_t e = 0; e < op.c_item->size(); ++e) by_item[(*op.c_item)[e]].push_back({i, e});
  }
  // (col0, cols) -> the items of that window, ascending, with their rows.
  std::map<std::pair<std::size_t, std::size_t>, std::vector<std::pair<std::uint32_t, std::vector<FaceRow>>>>
      windows;
  for (const auto& [item, rows] : by_item) {
    const std::size_t col0 = face0[rows.front().object],
                      col1 = face0[rows.back().object] + drt.objects[rows.back().object].face_count;
    std::size_t faces = 0;
    for (const FaceRow& r : rows) faces += drt.objects[r.object].face_count;
    if (col1 - col0 <= 2 * faces) {
      windows[{col0, col1 - col0}].push_back({item, rows});
    } else {
      for (const FaceRow& r : rows)
        windows[{face0[r.object], drt.objects[r.object].face_count}].push_back({item, {r}});
    }
  }
  for (const auto& [window, items] : windows) {
    FaceGroup g;
    g.col0 = std::uint32_t(window.first);
    g.row0 = d.shape.c_rows;
    g.rows = Matrix(std::uint32_t(W * items.size()), std::uint32_t(window.second));
    g.slot.reserve(W * items.size());
    for (std::size_t i = 0; i < items.size(); ++i) {
      for (const FaceRow& r : items[i].second) {
        const Matrix& src = *parts(drt.objects[r.object]).c;
        const std::size_t f = src.cols, offset = face0[r.object] - window.first;
        for (std::uint32_t w = 0; w < W; ++w)
          std::copy_n(src.row(std::uint32_t(W * r.entry + w)).data(), f,
                      g.rows.data.begin() + std::ptrdiff_t((W * i + w) * window.second + offset));
      }
      for (std::uint32_t w = 0; w < W; ++w) g.slot.push_back(std::int32_t(W * items[i].first + w));
    }
    d.shape.c_rows += g.rows.rows;
    d.shape.c_cells += g.rows.data.size();
    d.c.push_back(std::move(g));
  }
  d.shape.c_groups = d.c.size();
  d.c_values.assign(3 * d.shape.c_rows, 0.0f);
  d.c_from.assign(3 * (face0.empty() ? 0 : face0.back() + drt.objects.back().face_count), 0.0f);
  return d;
}

Result<CpuDrtRuntime> CpuDrtRuntime::create(const Level& level, const DrtOperators& drt,
                                            std::optional<Isa> isa) {
  const Isa chosen = isa.value_or(active_isa());
  if (!isa_supported(chosen))
    return Status::error(ErrorCode::invalid_argument,
                         std::string("cpu drt: ISA ") + isa_name(chosen) + " is not supported here");
  if (Status s = check_drt_operators(level, drt); !s.ok()) return s;
  CpuDrtRuntime rt;
  rt.level_ = &level;
  rt.drt_ = &drt;
  rt.isa_ = chosen;
  rt.sizes_ = drt_buffer_sizes(drt);
  rt.lightmap_size_ = 3 * std::size_t(level.sample_count);
  const std::size_t kb = level.kb;
  // The face groups read all of c, planar.
  std::size_t scratch = std::max(3 * kb, rt.sizes_.c), modes = 0, texel0 = 0, face0 = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    rt.texel0_.push_back(texel0);
    rt.face0_.push_back(face0);
    scratch =
        std::max({scratch, 3 * std::size_t(o.texel_count), 3 * kb * o.Cb_blocks.size(),
                  3 * std::size_t(o.Uc.cols), 3 * std::size_t(o.Cc.cols), 3 * kb * o.Cb_vec_blocks.size(),
                  3 * std::size_t(o.Uc_vec.cols), 3 * std::size_t(o.Cc_vec.cols)});
    modes = std::max<std::size_t>({modes, o.Uc.cols, o.Uc_vec.cols});
    texel0 += o.texel_count;
    face0 += o.face_count;
  }
  rt.lightmap_ = build_delta(drt, level.kb, DeltaKind::lightmap, rt.face0_);
  rt.vector_ = build_delta(drt, level.kb, DeltaKind::vector, rt.face0_);
  rt.probes_ = build_delta(drt, level.kb, DeltaKind::probes, rt.face0_);
  rt.planar_.assign(scratch, 0.0f);
  rt.modes_.assign(3 * std::max<std::size_t>(modes, 1), 0.0f);
  rt.cc_values_.assign(rt.sizes_.clutter_lightmap, 0.0f);
  rt.cc_from_.assign(rt.sizes_.c, 0.0f);
  return rt;
}

Status CpuDrtRuntime::compute_c(std::span<const float> clutter_ld, std::span<float> c) {
  if (clutter_ld.size() != sizes_.clutter_ld)
    return wrong_size("clutter_ld", clutter_ld.size(), sizes_.clutter_ld);
  if (c.size() != sizes_.c) return wrong_size("c", c.size(), sizes_.c);
  if (!finite_nonnegative(isa_, clutter_ld.data(), clutter_ld.size(), kMaxLightValue))
    if (Status s = validate_light_signal(clutter_ld, sizes_.clutter_texels, "clutter_ld"); !s.ok()) return s;
  for (std::size_t i = 0; i < drt_->objects.size(); ++i) {
    const DrtObjectOperators& o = drt_->objects[i];
    const std::size_t m = o.texel_count;
    deinterleave_rgb(clutter_ld.data() + 3 * texel0_[i], m, planar_.data(), m);
    gemv_rgb(isa_, o.Td_c.data.data(), o.face_count, m, m, planar_.data(), m, c.data() + 3 * face0_[i],
             false);
  }
  return Status::success();
}

Status CpuDrtRuntime::apply(std::span<const float> b, std::span<const float> c, std::span<float> lightmap) {
  const std::size_t kb = level_->kb;
  if (b.size() != 3 * kb * level_->blocks.size())
    return wrong_size("b", b.size(), 3 * kb * level_->blocks.size());
  if (c.size() != sizes_.c) return wrong_size("c", c.size(), sizes_.c);
  if (lightmap.size() != lightmap_size_) return wrong_size("lightmap", lightmap.size(), lightmap_size_);
  apply_delta(lightmap_, b, c, lightmap.data());
  return Status::success();
}

Status CpuDrtRuntime::clutter_lightmap(std::span<const float> b, std::span<const float> clutter_direct,
                                       std::span<float> out) {
  const std::size_t kb = level_->kb;
  if (b.size() != 3 * kb * level_->blocks.size())
    return wrong_size("b", b.size(), 3 * kb * level_->blocks.size());
  if (out.size() != sizes_.clutter_lightmap)
    return wrong_size("clutter lightmap", out.size(), sizes_.clutter_lightmap);
  if (!clutter_direct.empty() && clutter_direct.size() != sizes_.clutter_lightmap)
    return wrong_size("clutter direct light", clutter_direct.size(), sizes_.clutter_lightmap);
  for (std::size_t i = 0; i < drt_->objects.size(); ++i) {
    const DrtObjectOperators& o = drt_->objects[i];
    const std::size_t m = o.texel_count, modes = o.Uc.cols, cols = kb * o.Cb_blocks.size();
    float* dst = out.data() + 3 * texel0_[i];
    if (modes == 0 || cols == 0) {
      std::fill(dst, dst + 3 * m, 0.0f);
    } else {
      // DRT §4.3: Vc b over the blocks the clutter sees (b concatenated planar), then Uc.
      for (std::size_t k = 0; k < o.Cb_blocks.size(); ++k)
        for (std::size_t j = 0; j < kb; ++j)
          for (std::size_t ch = 0; ch < 3; ++ch)
            planar_[ch * cols + k * kb + j] = b[3 * kb * o.Cb_blocks[k] + 3 * j + ch];
      gemv_rgb(isa_, o.Vc.data.data(), modes, cols, cols, planar_.data(), cols, modes_.data(), false);
      deinterleave_rgb(modes_.data(), modes, planar_.data(), modes);
      gemv_rgb(isa_, o.Uc.data.data(), m, modes, modes, planar_.data(), modes, dst, false);
    }
    if (!clutter_direct.empty())
      for (std::size_t k = 0; k < 3 * m; ++k) dst[k] += clutter_direct[3 * texel0_[i] + k];
  }
  return Status::success();
}

Status CpuDrtRuntime::clutter_add_cc(std::span<const float> c, std::span<float> out) {
  if (c.size() != sizes_.c) return wrong_size("c", c.size(), sizes_.c);
  if (out.size() != sizes_.clutter_lightmap)
    return wrong_size("clutter lightmap", out.size(), sizes_.clutter_lightmap);
  if (!cc_valid_ || std::memcmp(c.data(), cc_from_.data(), c.size_bytes()) != 0) {
    std::fill(cc_values_.begin(), cc_values_.end(), 0.0f);
    for (std::size_t i = 0; i < drt_->objects.size(); ++i) {
      const DrtObjectOperators& o = drt_->objects[i];
      const std::size_t cols = o.Cc.cols;
      if (cols == 0) continue;
      // The c of the source objects' faces, planar in Cc's column order.
      std::size_t col = 0;
      for (std::uint32_t src : o.Cc_objects)
        for (std::size_t f = 0; f < drt_->objects[src].face_count; ++f, ++col)
          for (std::size_t ch = 0; ch < 3; ++ch) planar_[ch * cols + col] = c[3 * (face0_[src] + f) + ch];
      gemv_rgb(isa_, o.Cc.data.data(), o.texel_count, cols, cols, planar_.data(), cols,
               cc_values_.data() + 3 * texel0_[i], false);
    }
    std::copy(c.begin(), c.end(), cc_from_.begin());
    cc_valid_ = true;
  }
  for (std::size_t k = 0; k < out.size(); ++k) out[k] += cc_values_[k];
  return Status::success();
}

namespace {

// out[0..3) += sign * the weighted sum of row r's RGB triplets of x.
inline void add_gather_row(const DrtSparseRows& g, std::size_t r, const float* x, float sign, float* out) {
  float acc0 = 0.0f, acc1 = 0.0f, acc2 = 0.0f;
  for (std::uint32_t e = g.start[r], end = g.start[r + 1]; e < end; ++e) {
    const float w = g.weight[e];
    const float* v = x + 3 * std::size_t(g.index[e]);
    acc0 += w * v[0];
    acc1 += w * v[1];
    acc2 += w * v[2];
  }
  out[0] += sign * acc0;
  out[1] += sign * acc1;
  out[2] += sign * acc2;
}

}  // namespace

Status CpuDrtRuntime::apply_gather(std::span<const float> ld, std::span<const float> clutter_radiance,
                                   std::span<float> lightmap) {
  if (ld.size() != lightmap_size_) return wrong_size("ld", ld.size(), lightmap_size_);
  if (clutter_radiance.size() != sizes_.clutter_ld)
    return wrong_size("clutter radiance", clutter_radiance.size(), sizes_.clutter_ld);
  if (lightmap.size() != lightmap_size_) return wrong_size("lightmap", lightmap.size(), lightmap_size_);
  for (const DrtObjectOperators& o : drt_->objects)
    for (std::size_t r = 0; r < o.H_sample.size(); ++r) {
      float* out = lightmap.data() + 3 * std::size_t(o.H_sample[r]);
      add_gather_row(o.Hs, r, ld.data(), -1.0f, out);
      add_gather_row(o.Ht, r, clutter_radiance.data(), 1.0f, out);
    }
  return Status::success();
}

Status CpuDrtRuntime::clutter_add_gather(std::span<const float> ld, std::span<const float> clutter_radiance,
                                         std::span<float> out) {
  if (ld.size() != lightmap_size_) return wrong_size("ld", ld.size(), lightmap_size_);
  if (clutter_radiance.size() != sizes_.clutter_ld)
    return wrong_size("clutter radiance", clutter_radiance.size(), sizes_.clutter_ld);
  if (out.size() != sizes_.clutter_lightmap)
    return wrong_size("clutter lightmap", out.size(), sizes_.clutter_lightmap);
  for (std::size_t i = 0; i < drt_->objects.size(); ++i) {
    const DrtObjectOperators& o = drt_->objects[i];
    for (std::uint32_t t = 0; t < o.texel_count; ++t) {
      float* row = out.data() + 3 * (texel0_[i] + t);
      if (!o.Gs.empty()) add_gather_row(o.Gs, t, ld.data(), 1.0f, row);
      if (!o.Gt.empty()) add_gather_row(o.Gt, t, clutter_radiance.data(), 1.0f, row);
    }
  }
  return Status::success();
}

Status CpuDrtRuntime::clutter_vector_lightmap(std::span<const float> b, std::span<const float> c,
                                              std::span<float> out) {
  const std::size_t kb = level_->kb;
  if (b.size() != 3 * kb * level_->blocks.size())
    return wrong_size("b", b.size(), 3 * kb * level_->blocks.size());
  if (c.size() != sizes_.c) return wrong_size("c", c.size(), sizes_.c);
  if (out.size() != sizes_.clutter_vector_lightmap)
    return wrong_size("clutter vector lightmap", out.size(), sizes_.clutter_vector_lightmap);
  for (std::size_t i = 0; i < drt_->objects.size(); ++i) {
    const DrtObjectOperators& o = drt_->objects[i];
    const std::size_t rows = 4 * std::size_t(o.texel_count), modes = o.Uc_vec.cols,
                      cols = kb * o.Cb_vec_blocks.size();
    float* dst = out.data() + 12 * texel0_[i];
    if (modes == 0 || cols == 0) {
      std::fill(dst, dst + 3 * rows, 0.0f);
    } else {  // DRT §5: Vc_vec b over the blocks the clutter sees, then Uc_vec (as Cb).
      for (std::size_t k = 0; k < o.Cb_vec_blocks.size(); ++k)
        for (std::size_t j = 0; j < kb; ++j)
          for (std::size_t ch = 0; ch < 3; ++ch)
            planar_[ch * cols + k * kb + j] = b[3 * kb * o.Cb_vec_blocks[k] + 3 * j + ch];
      gemv_rgb(isa_, o.Vc_vec.data.data(), modes, cols, cols, planar_.data(), cols, modes_.data(), false);
      deinterleave_rgb(modes_.data(), modes, planar_.data(), modes);
      gemv_rgb(isa_, o.Uc_vec.data.data(), rows, modes, modes, planar_.data(), modes, dst, false);
    }
    const std::size_t cc_cols = o.Cc_vec.cols;
    if (cc_cols == 0) continue;
    std::size_t col = 0;
    for (std::uint32_t src : o.Cc_vec_objects)
      for (std::size_t f = 0; f < drt_->objects[src].face_count; ++f, ++col)
        for (std::size_t ch = 0; ch < 3; ++ch) planar_[ch * cc_cols + col] = c[3 * (face0_[src] + f) + ch];
    gemv_rgb(isa_, o.Cc_vec.data.data(), rows, cc_cols, cc_cols, planar_.data(), cc_cols, dst, true);
  }
  return Status::success();
}

void CpuDrtRuntime::apply_delta(Delta& delta, std::span<const float> b, std::span<const float> c,
                                float* out) {
  const std::size_t kb = level_->kb;
  for (const BlockGroup& g : delta.b) {
    deinterleave_rgb(b.data() + 3 * kb * g.block, kb, planar_.data(), kb);
    gemv_rgb_scatter(isa_, g.rows.data.data(), g.rows.rows, kb, kb, g.slot.data(), planar_.data(), kb, out);
  }
  if (delta.c.empty()) return;
  // The face rows read c alone. gemv_rgb_masked then add_scattered write the bits that
  // gemv_rgb_scatter writes, so reusing the values while c has the same bits changes nothing.
  if (!delta.c_valid || std::memcmp(c.data(), delta.c_from.data(), c.size_bytes()) != 0) {
    const std::size_t faces = c.size() / 3;
    deinterleave_rgb(c.data(), faces, planar_.data(), faces);
    for (const FaceGroup& g : delta.c)
      gemv_rgb_masked(isa_, g.rows.data.data(), g.rows.rows, g.rows.cols, g.rows.cols, g.slot.data(),
                      planar_.data() + g.col0, faces, delta.c_values.data() + 3 * g.row0);
    std::copy(c.begin(), c.end(), delta.c_from.begin());
    delta.c_valid = true;
  }
  for (const FaceGroup& g : delta.c)
    add_scattered(g.rows.rows, g.slot.data(), delta.c_values.data() + 3 * g.row0, out);
}

Status CpuDrtRuntime::apply_vector(std::span<const float> b, std::span<const float> c,
                                   std::span<float> vector_lightmap) {
  const std::size_t kb = level_->kb;
  if (b.size() != 3 * kb * level_->blocks.size())
    return wrong_size("b", b.size(), 3 * kb * level_->blocks.size());
  if (c.size() != sizes_.c) return wrong_size("c", c.size(), sizes_.c);
  if (vector_lightmap.size() != 4 * lightmap_size_)
    return wrong_size("vector lightmap", vector_lightmap.size(), 4 * lightmap_size_);
  apply_delta(vector_, b, c, vector_lightmap.data());
  return Status::success();
}

Status CpuDrtRuntime::apply_probes(std::span<const float> b, std::span<const float> c,
                                   std::span<float> probes) {
  const std::size_t kb = level_->kb;
  const std::size_t size = 27 * std::size_t(drt_->probes_per_block) * level_->blocks.size();
  if (b.size() != 3 * kb * level_->blocks.size())
    return wrong_size("b", b.size(), 3 * kb * level_->blocks.size());
  if (c.size() != sizes_.c) return wrong_size("c", c.size(), sizes_.c);
  // Operators without U_dyn rows add nothing, to probes of any grid (the backend has the
  // dictionary's and calls this every frame), whatever grid their file names.
  if (drt_->probes_per_block == 0 || (probes_.b.empty() && probes_.c.empty())) return Status::success();
  if (probes.size() != size) return wrong_size("probes", probes.size(), size);
  apply_delta(probes_, b, c, probes.data());
  return Status::success();
}

}  // namespace modrt::cpu
