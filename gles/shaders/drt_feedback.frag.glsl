// SPDX-License-Identifier: MIT
// Multi-bounce with clutter (docs/drt.md, "Multi-bounce"; core's drt_clutter_feedback): the
// clutter's light for the next bounce, clutter_ld + rho_c * min(max(indirect, 0), bound) per
// clutter texel, where indirect = the last evaluation's clutter atlas (Cb b + Cc c + direct)
// minus the direct light it added.
uniform sampler2D u_clutter_ld;  // per clutter texel, RGB
uniform sampler2D u_rho;         // per clutter texel, albedo clamped to max_albedo
uniform sampler2D u_direct;      // per clutter texel, RGB (zero when none was given)
uniform isampler2D u_texel_xy;   // per clutter texel: its clutter-atlas texel (x, y, 0, 0)
uniform OUTPUT_SAMPLER u_atlas;
uniform int u_count;
uniform float u_bound;

layout(location = 0) out uvec4 o_ld;

void main() {
  int t = fragment_index();
  vec3 ld = vec3(0.0);
  if (t < u_count) {
    ivec4 xy = load_int(u_texel_xy, t);
    vec3 indirect = load_output_2d(u_atlas, xy.xy).rgb - load(u_direct, t).rgb;
    ld = load(u_clutter_ld, t).rgb + load(u_rho, t).rgb * min(max(indirect, vec3(0.0)), vec3(u_bound));
  }
  o_ld = store_signal(vec4(ld, 1.0));
}
