// SPDX-License-Identifier: MIT
// modrt — the multi-bounce feedback policy (architecture.md §2 and §5 step 8,
// docs/robustness.md "multi-bounce"): each formula stated once, for the scalar reference,
// modrt::cpu, modrt::gles and DRT's clutter feedback alike.
//
// Feedback is ld = ld_direct + rho * min(max(lightmap, 0), bound). With every albedo clamped to
// rho <= max_albedo < 1, the bounce series is geometric with ratio <= rho_max, so no texel
// can exceed bound = ld_max / (1 - rho_max) (ld_max: the largest direct light); clamping the
// fed-back lightmap there keeps a numerically wrong operator from growing light without bound.
#pragma once

#include <algorithm>
#include <span>

#include "modrt/status.h"

namespace modrt {

// The default clamp of every albedo in the feedback (MultiBounceSettings, Backend::set_albedo).
inline constexpr float kDefaultMaxAlbedo = 0.95f;

// max_albedo must lie in [0, 1); `who` starts the message ("cpu: set_clutter_albedo").
inline Status check_max_albedo(float max_albedo, const char* who) {
  if (max_albedo >= 0.0f && max_albedo < 1.0f) return Status::success();
  return Status::error(ErrorCode::invalid_argument, std::string(who) + ": max_albedo must be in [0, 1)");
}

// rho = min(albedo, max_albedo), elementwise (rho.size() == albedo.size(); rho may alias
// albedo). The largest rho, and whether any value was clamped.
struct ClampedAlbedo {
  float rho_max = 0.0f;
  bool clamped = false;
};
inline ClampedAlbedo clamp_albedo(std::span<const float> albedo, float max_albedo, std::span<float> rho) {
  ClampedAlbedo out;
  for (std::size_t i = 0; i < albedo.size(); ++i) {
    const float v = albedo[i];
    out.clamped |= v > max_albedo;
    rho[i] = std::min(v, max_albedo);
    out.rho_max = std::max(out.rho_max, rho[i]);
  }
  return out;
}

// The largest value of a (validated, non-negative) light signal; 0 when empty.
inline float largest_light(std::span<const float> light) {
  return light.empty() ? 0.0f : *std::max_element(light.begin(), light.end());
}
// clamp_albedo's rho_max without writing rho: max(min(a, m)) = min(max(a), m).
inline float largest_clamped_albedo(std::span<const float> albedo, float max_albedo) {
  return std::min(largest_light(albedo), max_albedo);
}

// The most a texel can reach: ld_max / (1 - rho_max), rho_max < 1 (check_max_albedo).
inline float feedback_energy_bound(float ld_max, float rho_max) { return ld_max / (1.0f - rho_max); }

// The largest fed-back ld a feedback step can produce, ld_max + rho_max x bound, grown by a
// relative 1e-6 for the float rounding of the step's own product and sum (a few 6e-8 each).
// In double: it is compared with kMaxLightValue, the largest light value every pass accepts,
// so that a step is refused before it runs rather than half way.
inline double feedback_ld_peak(float ld_max, float rho_max) {
  return (double(ld_max) + double(rho_max) * double(feedback_energy_bound(ld_max, rho_max))) * (1.0 + 1e-6);
}

}  // namespace modrt
