// SPDX-License-Identifier: MIT
// Step 8, one multi-bounce iteration (architecture.md §2): ld = ld_direct + rho * min(max(lightmap, 0),
// bound), bound = max(ld_direct) / (1 - max rho), the same clamp as core's apply_feedback so
// that feedback cannot diverge. The lightmap is the previous frame's atlas.
// ld_direct is the CPU's upload (validated there, bound computed there: u_bound) or the
// caller's texture (read through sanitize_light; bound = the ld_max pass's value x
// u_bound_scale = 1 / (1 - max rho), and the fed-back ld clamped at MAX_LIGHT, where the CPU
// path refuses an ld whose bounces could pass it).
uniform sampler2D u_ld_direct;     // per sample, RGB
uniform sampler2D u_rho;           // per sample, albedo clamped to max_albedo
uniform isampler2D u_sample_info;  // per sample: (block, t, atlas x, atlas y)
uniform OUTPUT_SAMPLER u_atlas;
uniform usampler2D u_ld_max;       // ld_max.frag's texel
uniform int u_count;
uniform float u_bound;
uniform float u_bound_scale;       // 0: u_bound

layout(location = 0) out uvec4 o_ld;

void main() {
  int s = fragment_index();
  vec3 ld = vec3(0.0);
  if (s < u_count) {
    ivec4 info = load_int(u_sample_info, s);
    vec3 lightmap = load_output_2d(u_atlas, info.zw).rgb;
    float bound = u_bound_scale > 0.0 ? load_signal(u_ld_max, 0).r * u_bound_scale : u_bound;
    ld = sanitize_light(load(u_ld_direct, s).rgb) + load(u_rho, s).rgb * min(max(lightmap, vec3(0.0)), vec3(bound));
    ld = min(ld, vec3(MAX_LIGHT));
  }
  o_ld = store_signal(vec4(ld, 1.0));
}
