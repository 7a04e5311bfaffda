// SPDX-License-Identifier: MIT
// Direct light at the level's proxy samples (architecture.md §5 step 1): the "geometry images" hold each
// sample's world position and inward normal, one texel per sample in a linear layout
// LD_WIDTH wide; ld = albedo * E/pi with the same light and shadow map as the camera image.
uniform sampler2D u_sample_position;
uniform sampler2D u_sample_normal;
uniform sampler2D u_sample_albedo;
uniform int u_count;
layout(location = 0) out vec4 o_ld;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  int i = p.y * LD_WIDTH + p.x;
  if (i >= u_count) {
    o_ld = vec4(0.0);
    return;
  }
  vec3 x = texelFetch(u_sample_position, p, 0).xyz;
  vec3 n = texelFetch(u_sample_normal, p, 0).xyz;
  o_ld = vec4(texelFetch(u_sample_albedo, p, 0).rgb * direct_e_over_pi(x, n), 1.0);
}
