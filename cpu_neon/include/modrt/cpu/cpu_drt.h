// SPDX-License-Identifier: MIT
// modrt::cpu — the DRT stages on the SIMD CPU path (architecture.md §5 step 7, [Loos et al. 2012] §5):
// c = Td_c clutter_ld, lightmap += dUb b + dUc c, clutter lightmap = Uc (Vc b) + direct
// (+ Cc c, clutter-to-clutter light), and the vector and probe deltas, with the GEMV kernels
// of kernels.h. Equal to core's drt_compute_c / drt_apply / drt_clutter_lightmap /
// drt_clutter_add_cc / drt_apply_vector / drt_apply_probes within 1e-5 relative
// (tests/test_cpu_drt.cpp).
//
// Layout chosen at creation: the dUb rows of all objects are merged and regrouped by the block
// whose b they read, one dense GEMV per block scattered onto its samples, instead of core's
// per-object, per-row (sample, block) order. Rows of different objects for the same (sample,
// block) read the same b, so they are summed (in double, stored float) into one: a sample
// under several objects' shadows costs one row per block it sees. Likewise dUb_vec and Udyn.
// The face rows (dUc, dUc_vec, Udyn_c) multiply each object's own c; an item's rows of several
// objects are concatenated into one row over the window of the concatenated c that spans
// those objects' faces, when the window holds at most twice their faces (else each object's
// row stays alone). The face rows' values are kept while c stays the same bit for bit (it
// changes with the clutter's light, not every frame) and only scattered again.
// A scene without clutter (empty operators) costs nothing.
// b is the CpuLevelRuntime's (interleaved, 3 kb per block). Nothing is allocated per call.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "modrt/cpu/isa.h"
#include "modrt/drt.h"
#include "modrt/level.h"
#include "modrt/status.h"

namespace modrt::cpu {

class CpuDrtRuntime {
 public:
  // Checks the operators against the level (check_drt_operators). `level` and `drt` are
  // borrowed for the runtime's life. isa: none = active_isa().
  static Result<CpuDrtRuntime> create(const Level& level, const DrtOperators& drt,
                                      std::optional<Isa> isa = {});

  const DrtBufferSizes& sizes() const { return sizes_; }
  // c (3 per clutter face) from the clutter's direct light (3 per clutter texel).
  Status compute_c(std::span<const float> clutter_ld, std::span<float> c);
  // lightmap (3 per level sample) += dUb b + dUc c.
  Status apply(std::span<const float> b, std::span<const float> c, std::span<float> lightmap);
  // out (3 per clutter texel) = Uc (Vc b) + clutter_direct (empty: none).
  Status clutter_lightmap(std::span<const float> b, std::span<const float> clutter_direct,
                          std::span<float> out);
  // out (3 per clutter texel) += Cc c: light of other clutter objects (drt.h
  // drt_clutter_add_cc); nothing for objects without Cc.
  Status clutter_add_cc(std::span<const float> c, std::span<float> out);
  // The real-radiance gather (drt.h DrtObjectOperators::Gs ... Ht), x_s = ld (3 per level
  // sample) and x_t = the clutter's light (3 per clutter texel): lightmap += Ht x_t - Hs x_s
  // (drt_apply_gather) and out += Gs x_s + Gt x_t (drt_clutter_add_gather); nothing for objects
  // without it. Sparse rows of RGB triplets: one loop for every ISA, accumulated in float.
  Status apply_gather(std::span<const float> ld, std::span<const float> clutter_radiance,
                      std::span<float> lightmap);
  Status clutter_add_gather(std::span<const float> ld, std::span<const float> clutter_radiance,
                            std::span<float> out);
  // out (12 per clutter texel) = Uc_vec (Vc_vec b) + Cc_vec c: the clutter's vector
  // irradiance (drt.h drt_clutter_vector_lightmap); zeros for objects without it.
  Status clutter_vector_lightmap(std::span<const float> b, std::span<const float> c, std::span<float> out);
  // vector_lightmap (12 per level sample, level_compute_vector_irradiance's layout) +=
  // dUb_vec b + dUc_vec c (drt.h drt_apply_vector); nothing for objects without them.
  Status apply_vector(std::span<const float> b, std::span<const float> c, std::span<float> vector_lightmap);
  // probes (level_compute_probes' layout, 27 per probe) += Udyn b + Udyn_c c (drt.h
  // drt_apply_probes); nothing for objects without U_dyn.
  Status apply_probes(std::span<const float> b, std::span<const float> c, std::span<float> probes);

  // The merged layout of one delta (matrix rows, so 4 per entry for the vector delta and 9
  // for the probes): b_rows against the objects' summed dUb / dUb_vec / Udyn rows shows the
  // merge; c_cells (rows x window columns, zeros included) against their dUc cells the cost
  // of the concatenation.
  struct DeltaShape {
    std::size_t b_rows = 0, b_groups = 0;               // one group (GEMV) per source block
    std::size_t c_rows = 0, c_groups = 0, c_cells = 0;  // one group per window of c
  };
  const DeltaShape& lightmap_shape() const { return lightmap_.shape; }
  const DeltaShape& vector_shape() const { return vector_.shape; }
  const DeltaShape& probe_shape() const { return probes_.shape; }

 private:
  CpuDrtRuntime() = default;
  struct BlockGroup {  // the merged rows that read one block's b
    std::uint32_t block = 0;
    Matrix rows;                     // rows x kb
    std::vector<std::int32_t> slot;  // output slot (3 floats) of each row: level sample, or
                                     // 4 sample + i (vector), 9 probe + j (probes)
  };
  struct FaceGroup {  // the face rows that read columns [col0, col0 + rows.cols) of c
    std::uint32_t col0 = 0;
    std::size_t row0 = 0;  // its first row in Delta::c_values
    Matrix rows;
    std::vector<std::int32_t> slot;
  };
  struct Delta {
    std::vector<BlockGroup> b;
    std::vector<FaceGroup> c;
    DeltaShape shape;
    // The face rows' values (3 per row) for the c they were computed from (c_from).
    std::vector<float> c_values, c_from;
    bool c_valid = false;
  };
  enum class DeltaKind { lightmap, vector, probes };
  static Delta build_delta(const DrtOperators& drt, std::uint32_t kb, DeltaKind kind,
                           const std::vector<std::size_t>& face0);
  // out += the block groups times b and the face groups times c.
  void apply_delta(Delta& delta, std::span<const float> b, std::span<const float> c, float* out);
  const Level* level_ = nullptr;
  const DrtOperators* drt_ = nullptr;
  Isa isa_ = Isa::scalar;
  DrtBufferSizes sizes_;
  std::size_t lightmap_size_ = 0;
  std::vector<std::size_t> texel0_, face0_;  // per object: its first clutter texel and c face
  Delta lightmap_, vector_, probes_;
  std::vector<float> planar_, modes_;  // scratch: the largest planar input, Vc b per mode
  // Cc c (3 per clutter texel) for the c it was computed from: c changes only with the
  // clutter's light (and multi-bounce feedback), so most frames add the kept values.
  std::vector<float> cc_values_, cc_from_;
  bool cc_valid_ = false;
};

}  // namespace modrt::cpu
