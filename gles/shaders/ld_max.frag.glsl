// SPDX-License-Identifier: MIT
// The largest value of the caller's ld texture (every sample and channel, read as b.frag reads
// it: sanitize_light), for the multi-bounce bound when ld stays on the GPU
// (GlesLevelRuntime::multi_bounce_step_from_texture; feedback_policy.h: bound = ld_max /
// (1 - rho_max)). Two passes, no readback: STAGE 1 takes the largest value of each row of
// LINEAR_WIDTH samples, STAGE 2 the largest of the rows, into one texel (.r).
#if STAGE == 1
uniform sampler2D u_ld;
#else
uniform usampler2D u_rows;
#endif
uniform int u_count;  // samples (stage 1) or rows (stage 2)

layout(location = 0) out uvec4 o_max;

void main() {
  int i = fragment_index();
  float m = 0.0;
#if STAGE == 1
  for (int x = 0; x < LINEAR_WIDTH; ++x) {
    int s = i * LINEAR_WIDTH + x;
    if (s >= u_count) break;
    vec3 l = sanitize_light(load(u_ld, s).rgb);
    m = max(m, max(l.r, max(l.g, l.b)));
  }
#else
  if (i == 0)
    for (int r = 0; r < u_count; ++r) m = max(m, load_signal(u_rows, r).r);
#endif
  o_max = store_signal(vec4(m, 0.0, 0.0, 1.0));
}
