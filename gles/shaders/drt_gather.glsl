// SPDX-License-Identifier: MIT
// The real-radiance gather (drt.h, DrtObjectOperators::Gs, Gt, Hs, Ht; docs/drt.md, "Gathering
// the real radiance"), between common.glsl and the two passes built with GATHER: drt_delta.frag
// (Ht x_t - Hs x_s per level sample) and drt_clutter.frag (Gs x_s + Gt x_t per clutter texel).
// A row is a run of entries in u_gather, one RG32UI texel each: (column, float bits of its
// non-negative weight), kept float32 whatever the OperatorFormat. The columns index x_s
// (u_xs: this evaluation's ld, the one Td_b reads, per level sample) or x_t (u_xt: the
// clutter's light, clutter_ld or the fed-back light, per clutter texel), both signals.
uniform usampler2D u_gather;
uniform usampler2D u_xs, u_xt;

// The sum over entries [first, first + n) of weight * x[column], per channel.
vec3 gather_row(usampler2D x, int first, int n) {
  vec3 acc = vec3(0.0);
  for (int e = first; e < first + n; ++e) {
    uvec2 entry = texelFetch(u_gather, lin(e), 0).xy;
    acc += uintBitsToFloat(entry.y) * load_signal(x, int(entry.x)).rgb;
  }
  return acc;
}
