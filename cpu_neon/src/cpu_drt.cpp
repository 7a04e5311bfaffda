#include "modrt/cpu/cpu_drt.h"

#include <algorithm>
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

}  // namespace

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
  std::size_t scratch = 3 * kb, modes = 0, texel0 = 0, face0 = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    Object obj;
    obj.texel0 = texel0;
    obj.face0 = face0;
    // dUb rows regrouped by source block, each group a dense matrix (DRT §4.1).
    std::map<std::uint32_t, std::vector<std::size_t>> by_block;
    for (std::size_t r = 0; r < o.dUb_block.size(); ++r) by_block[o.dUb_block[r]].push_back(r);
    for (const auto& [block, rows] : by_block) {
      BlockGroup g;
      g.block = block;
      g.rows = Matrix(std::uint32_t(rows.size()), std::uint32_t(kb));
      for (std::size_t i = 0; i < rows.size(); ++i) {
        const std::span<const float> src = o.dUb.row(std::uint32_t(rows[i]));
        std::copy(src.begin(), src.end(), g.rows.data.begin() + std::ptrdiff_t(i * kb));
        g.sample.push_back(std::int32_t(o.dUb_sample[rows[i]]));
      }
      obj.groups.push_back(std::move(g));
    }
    obj.dUc_sample.assign(o.dUc_sample.begin(), o.dUc_sample.end());
    // The vector and probe deltas: W matrix rows per (sample or probe, block) entry, grouped
    // by block the same way, each row scattered to its coefficient's output slot.
    auto regroup = [&](const Matrix& A, const std::vector<std::uint32_t>& index,
                       const std::vector<std::uint32_t>& block_of, std::uint32_t W,
                       std::vector<BlockGroup>& out) {
      std::map<std::uint32_t, std::vector<std::size_t>> entries;
      for (std::size_t e = 0; e < block_of.size(); ++e) entries[block_of[e]].push_back(e);
      for (const auto& [block, list] : entries) {
        BlockGroup g;
        g.block = block;
        g.rows = Matrix(std::uint32_t(W * list.size()), std::uint32_t(kb));
        for (std::size_t i = 0; i < list.size(); ++i)
          for (std::uint32_t w = 0; w < W; ++w) {
            const std::span<const float> src = A.row(std::uint32_t(W * list[i] + w));
            std::copy(src.begin(), src.end(), g.rows.data.begin() + std::ptrdiff_t((W * i + w) * kb));
            g.sample.push_back(std::int32_t(W * index[list[i]] + w));
          }
        out.push_back(std::move(g));
      }
    };
    regroup(o.dUb_vec, o.dUb_vec_sample, o.dUb_vec_block, 4, obj.vector_groups);
    regroup(o.Udyn, o.Udyn_probe, o.Udyn_block, 9, obj.probe_groups);
    for (std::uint32_t smp : o.dUc_vec_sample)
      for (std::int32_t i = 0; i < 4; ++i) obj.dUc_vec_slot.push_back(std::int32_t(4 * smp) + i);
    for (std::uint32_t p : o.Udyn_c_probe)
      for (std::int32_t j = 0; j < 9; ++j) obj.Udyn_c_slot.push_back(std::int32_t(9 * p) + j);
    scratch = std::max({scratch, 3 * std::size_t(o.texel_count), 3 * std::size_t(o.face_count),
                        3 * kb * o.Cb_blocks.size(), 3 * std::size_t(o.Uc.cols), 3 * std::size_t(o.Cc.cols)});
    modes = std::max<std::size_t>(modes, o.Uc.cols);
    texel0 += o.texel_count;
    face0 += o.face_count;
    rt.objects_.push_back(std::move(obj));
  }
  rt.planar_.assign(scratch, 0.0f);
  rt.modes_.assign(3 * std::max<std::size_t>(modes, 1), 0.0f);
  return rt;
}

Status CpuDrtRuntime::compute_c(std::span<const float> clutter_ld, std::span<float> c) {
  if (clutter_ld.size() != sizes_.clutter_ld)
    return wrong_size("clutter_ld", clutter_ld.size(), sizes_.clutter_ld);
  if (c.size() != sizes_.c) return wrong_size("c", c.size(), sizes_.c);
  if (!finite_nonnegative(isa_, clutter_ld.data(), clutter_ld.size(), kMaxLightValue))
    if (Status s = validate_light_signal(clutter_ld, sizes_.clutter_texels, "clutter_ld"); !s.ok()) return s;
  for (std::size_t i = 0; i < objects_.size(); ++i) {
    const DrtObjectOperators& o = drt_->objects[i];
    const std::size_t m = o.texel_count;
    deinterleave_rgb(clutter_ld.data() + 3 * objects_[i].texel0, m, planar_.data(), m);
    gemv_rgb(isa_, o.Td_c.data.data(), o.face_count, m, m, planar_.data(), m,
             c.data() + 3 * objects_[i].face0, false);
  }
  return Status::success();
}

Status CpuDrtRuntime::apply(std::span<const float> b, std::span<const float> c, std::span<float> lightmap) {
  const std::size_t kb = level_->kb;
  if (b.size() != 3 * kb * level_->blocks.size())
    return wrong_size("b", b.size(), 3 * kb * level_->blocks.size());
  if (c.size() != sizes_.c) return wrong_size("c", c.size(), sizes_.c);
  if (lightmap.size() != lightmap_size_) return wrong_size("lightmap", lightmap.size(), lightmap_size_);
  for (std::size_t i = 0; i < objects_.size(); ++i) {
    const Object& obj = objects_[i];
    for (const BlockGroup& g : obj.groups) {
      deinterleave_rgb(b.data() + 3 * kb * g.block, kb, planar_.data(), kb);
      gemv_rgb_scatter(isa_, g.rows.data.data(), g.rows.rows, kb, kb, g.sample.data(), planar_.data(), kb,
                       lightmap.data());
    }
    const DrtObjectOperators& o = drt_->objects[i];
    if (!obj.dUc_sample.empty()) {  // DRT §4.2
      const std::size_t f = o.face_count;
      deinterleave_rgb(c.data() + 3 * obj.face0, f, planar_.data(), f);
      gemv_rgb_scatter(isa_, o.dUc.data.data(), o.dUc.rows, f, f, obj.dUc_sample.data(), planar_.data(), f,
                       lightmap.data());
    }
  }
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
  for (std::size_t i = 0; i < objects_.size(); ++i) {
    const DrtObjectOperators& o = drt_->objects[i];
    const std::size_t m = o.texel_count, modes = o.Uc.cols, cols = kb * o.Cb_blocks.size();
    float* dst = out.data() + 3 * objects_[i].texel0;
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
      for (std::size_t k = 0; k < 3 * m; ++k) dst[k] += clutter_direct[3 * objects_[i].texel0 + k];
  }
  return Status::success();
}

Status CpuDrtRuntime::clutter_add_cc(std::span<const float> c, std::span<float> out) {
  if (c.size() != sizes_.c) return wrong_size("c", c.size(), sizes_.c);
  if (out.size() != sizes_.clutter_lightmap)
    return wrong_size("clutter lightmap", out.size(), sizes_.clutter_lightmap);
  for (std::size_t i = 0; i < objects_.size(); ++i) {
    const DrtObjectOperators& o = drt_->objects[i];
    const std::size_t cols = o.Cc.cols;
    if (cols == 0) continue;
    // The c of the source objects' faces, planar in Cc's column order.
    std::size_t col = 0;
    for (std::uint32_t src : o.Cc_objects)
      for (std::size_t f = 0; f < drt_->objects[src].face_count; ++f, ++col)
        for (std::size_t ch = 0; ch < 3; ++ch)
          planar_[ch * cols + col] = c[3 * (objects_[src].face0 + f) + ch];
    gemv_rgb(isa_, o.Cc.data.data(), o.texel_count, cols, cols, planar_.data(), cols,
             out.data() + 3 * objects_[i].texel0, true);
  }
  return Status::success();
}

void CpuDrtRuntime::apply_groups(std::span<const float> b, const std::vector<BlockGroup>& groups,
                                 const Matrix& face_rows, const std::vector<std::int32_t>& face_slot,
                                 const float* c_object, std::size_t faces, float* out) {
  const std::size_t kb = level_->kb;
  for (const BlockGroup& g : groups) {
    deinterleave_rgb(b.data() + 3 * kb * g.block, kb, planar_.data(), kb);
    gemv_rgb_scatter(isa_, g.rows.data.data(), g.rows.rows, kb, kb, g.sample.data(), planar_.data(), kb, out);
  }
  if (!face_slot.empty()) {
    deinterleave_rgb(c_object, faces, planar_.data(), faces);
    gemv_rgb_scatter(isa_, face_rows.data.data(), face_rows.rows, faces, faces, face_slot.data(),
                     planar_.data(), faces, out);
  }
}

Status CpuDrtRuntime::apply_vector(std::span<const float> b, std::span<const float> c,
                                   std::span<float> vector_lightmap) {
  const std::size_t kb = level_->kb;
  if (b.size() != 3 * kb * level_->blocks.size())
    return wrong_size("b", b.size(), 3 * kb * level_->blocks.size());
  if (c.size() != sizes_.c) return wrong_size("c", c.size(), sizes_.c);
  if (vector_lightmap.size() != 4 * lightmap_size_)
    return wrong_size("vector lightmap", vector_lightmap.size(), 4 * lightmap_size_);
  for (std::size_t i = 0; i < objects_.size(); ++i) {
    const DrtObjectOperators& o = drt_->objects[i];
    apply_groups(b, objects_[i].vector_groups, o.dUc_vec, objects_[i].dUc_vec_slot,
                 c.data() + 3 * objects_[i].face0, o.face_count, vector_lightmap.data());
  }
  return Status::success();
}

Status CpuDrtRuntime::apply_probes(std::span<const float> b, std::span<const float> c,
                                   std::span<float> probes) {
  const std::size_t kb = level_->kb;
  const std::size_t size = 27 * std::size_t(drt_->probes_per_block) * level_->blocks.size();
  if (b.size() != 3 * kb * level_->blocks.size())
    return wrong_size("b", b.size(), 3 * kb * level_->blocks.size());
  if (c.size() != sizes_.c) return wrong_size("c", c.size(), sizes_.c);
  if (probes.size() != size) return wrong_size("probes", probes.size(), size);
  for (std::size_t i = 0; i < objects_.size(); ++i) {
    const DrtObjectOperators& o = drt_->objects[i];
    apply_groups(b, objects_[i].probe_groups, o.Udyn_c, objects_[i].Udyn_c_slot,
                 c.data() + 3 * objects_[i].face0, o.face_count, probes.data());
  }
  return Status::success();
}

}  // namespace modrt::cpu
