// SPDX-License-Identifier: MIT
// Multi-bounce with clutter (docs/drt.md, "Multi-bounce"; core's drt_clutter_feedback): the
// clutter's light for the next bounce, clutter_ld + rho_c * min(max(indirect, 0), bound) per
// clutter texel, where indirect = the last evaluation's clutter atlas (Cb b + Cc c + direct)
// minus the direct light it added. LINEAR 1 (the converged solve, gles_reduced_solve.cpp): the
// same without clamps, clutter_ld + u_scale * rho_c * indirect (core's reduced_clutter_feedback).
uniform sampler2D u_clutter_ld;  // per clutter texel, RGB
uniform sampler2D u_rho;         // per clutter texel, albedo clamped to max_albedo
uniform sampler2D u_direct;      // per clutter texel, RGB (zero when none was given)
uniform isampler2D u_texel_xy;   // per clutter texel: its clutter-atlas texel (x, y, 0, 0)
uniform OUTPUT_SAMPLER u_atlas;
uniform usampler2D u_ld_max;  // with the walls' ld on the GPU: ld_max.frag's texel
uniform int u_count;
uniform float u_bound;
// 0: u_bound (from the CPU). Else bound = max(the walls' ld_max, u_clutter_ld_max) x
// u_bound_scale (= 1 / (1 - max albedo)), drt_feedback_bound with ld_max found on the GPU.
uniform float u_bound_scale;
uniform float u_clutter_ld_max;
uniform float u_scale;  // LINEAR: the damping s
#ifndef LINEAR
#define LINEAR 0
#endif

layout(location = 0) out uvec4 o_ld;

void main() {
  int t = fragment_index();
  vec3 ld = vec3(0.0);
  if (t < u_count) {
    ivec4 xy = load_int(u_texel_xy, t);
    vec3 indirect = load_output_2d(u_atlas, xy.xy).rgb - load(u_direct, t).rgb;
#if LINEAR
    ld = load(u_clutter_ld, t).rgb + u_scale * load(u_rho, t).rgb * indirect;
#else
    float bound =
        u_bound_scale > 0.0 ? max(load_signal(u_ld_max, 0).r, u_clutter_ld_max) * u_bound_scale : u_bound;
    ld = load(u_clutter_ld, t).rgb + load(u_rho, t).rgb * min(max(indirect, vec3(0.0)), vec3(bound));
    ld = min(ld, vec3(MAX_LIGHT));
#endif
  }
  o_ld = store_signal(vec4(ld, 1.0));
}
