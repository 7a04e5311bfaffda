// SPDX-License-Identifier: MIT
// The real-radiance gather's inputs as signals (drt_gather.glsl), one fragment per item: this
// evaluation's ld (x_s, per level sample) when it is the caller's upload or texture, and the
// clutter's direct light clutter_ld (x_t, per clutter texel), so that the gather passes read
// both through one sampler type whatever their source (the feedback pass's ld and
// drt_feedback.frag's fed-back light are signals already). Read as b.frag reads ld, through
// sanitize_light, which leaves a validated upload unchanged.
uniform sampler2D u_light;  // per item, RGB
uniform int u_count;        // items

layout(location = 0) out uvec4 o_light;

void main() {
  int i = fragment_index();
  vec3 light = vec3(0.0);
  if (i < u_count) light = sanitize_light(load(u_light, i).rgb);
  o_light = store_signal(vec4(light, 0.0));
}
