// modrt::cpu — the DRT stages on the SIMD CPU path (SPEC §5 step 7, [Loos et al. 2012] §5):
// c = Td_c clutter_ld, lightmap += dUb b + dUc c, clutter lightmap = Uc (Vc b) + direct
// (+ Cc c, clutter-to-clutter light), and the vector and probe deltas, with the GEMV kernels
// of kernels.h. Equal to core's drt_compute_c / drt_apply / drt_clutter_lightmap /
// drt_clutter_add_cc / drt_apply_vector / drt_apply_probes within 1e-5 relative
// (tests/test_cpu_drt.cpp).
//
// Layout chosen at creation: each object's dUb rows are regrouped by the block whose b they
// read (one dense GEMV per group, scattered onto its samples), instead of core's per-row
// (sample, block) order. A scene without clutter (empty operators) costs nothing.
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
  // vector_lightmap (12 per level sample, level_compute_vector_irradiance's layout) +=
  // dUb_vec b + dUc_vec c (drt.h drt_apply_vector); nothing for objects without them.
  Status apply_vector(std::span<const float> b, std::span<const float> c, std::span<float> vector_lightmap);
  // probes (level_compute_probes' layout, 27 per probe) += Udyn b + Udyn_c c (drt.h
  // drt_apply_probes); nothing for objects without U_dyn.
  Status apply_probes(std::span<const float> b, std::span<const float> c, std::span<float> probes);

 private:
  CpuDrtRuntime() = default;
  struct BlockGroup {  // the dUb rows of one object that read one block's b
    std::uint32_t block = 0;
    Matrix rows;                       // rows x kb
    std::vector<std::int32_t> sample;  // output slot (3 floats) of each row: level sample, or
                                       // 4 sample + i (vector), 9 probe + j (probes)
  };
  struct Object {
    std::vector<BlockGroup> groups, vector_groups, probe_groups;
    std::vector<std::int32_t> dUc_sample, dUc_vec_slot, Udyn_c_slot;
    std::size_t texel0 = 0, face0 = 0;
  };
  // out += the grouped rows times b (by block) and face_rows times the object's c.
  void apply_groups(std::span<const float> b, const std::vector<BlockGroup>& groups, const Matrix& face_rows,
                    const std::vector<std::int32_t>& face_slot, const float* c_object, std::size_t faces,
                    float* out);
  const Level* level_ = nullptr;
  const DrtOperators* drt_ = nullptr;
  Isa isa_ = Isa::scalar;
  DrtBufferSizes sizes_;
  std::size_t lightmap_size_ = 0;
  std::vector<Object> objects_;
  std::vector<float> planar_, modes_;  // scratch: the largest planar input, Vc b per mode
};

}  // namespace modrt::cpu
