// SPDX-License-Identifier: MIT
// Second half of a split sum (b.frag, r.frag): out[i] = sum of the PARTS partial sums
// in[i * PARTS] ... in[i * PARTS + PARTS - 1], for the three channel planes. PARTS is
// B_CHUNKS for b and GROUPS for r (defined per program).
uniform usampler2D u_partial_red, u_partial_green, u_partial_blue;
uniform int u_count;  // outputs

layout(location = 0) out uvec4 o_red;
layout(location = 1) out uvec4 o_green;
layout(location = 2) out uvec4 o_blue;

void main() {
  int i = fragment_index();
  vec4 red = vec4(0.0), green = vec4(0.0), blue = vec4(0.0);
  if (i < u_count) {
    int p = i * PARTS;
    for (int c = 0; c < PARTS; ++c) {
      red += load_signal(u_partial_red, p + c);
      green += load_signal(u_partial_green, p + c);
      blue += load_signal(u_partial_blue, p + c);
    }
  }
  o_red = store_signal(red);
  o_green = store_signal(green);
  o_blue = store_signal(blue);
}
