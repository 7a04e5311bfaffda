// SPDX-License-Identifier: MIT
// Direct light at the level's proxy samples (architecture.md §5 step 1): the sample images hold
// each sample's world position, inward normal and albedo, one texel per sample in the runtime's
// linear layout (sample s at (s % LINEAR_WIDTH, s / LINEAR_WIDTH)); ld = albedo * E/pi of
// light.glsl. The output is what GlesLevelRuntime::update_from_texture reads.
uniform sampler2D u_sample_position;
uniform sampler2D u_sample_normal;
uniform sampler2D u_sample_albedo;
uniform int u_count;
layout(location = 0) out vec4 o_ld;
void main() {
  int i = fragment_index();
  if (i >= u_count) {
    o_ld = vec4(0.0);
    return;
  }
  vec3 x = load(u_sample_position, i).xyz;
  vec3 n = load(u_sample_normal, i).xyz;
  o_ld = vec4(load(u_sample_albedo, i).rgb * direct_e_over_pi(x, n), 1.0);
}
