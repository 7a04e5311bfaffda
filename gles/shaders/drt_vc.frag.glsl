// SPDX-License-Identifier: MIT
// DRT §4.3, first half of Cb b = Uc (Vc b): y = Vc b, one fragment per (object, mode) over the
// b of the blocks the clutter sees. Vc row q of an object is packed GROUPS texels per seen
// block (four modes per texel), the blocks in Cb_blocks order.
uniform sampler2D u_vc;
uniform isampler2D u_mode_info;  // per (object, mode): (first Vc texel, first Cb block entry, Cb block count, 0)
uniform isampler2D u_cb_blocks;  // the objects' Cb_blocks lists: (block, 0, 0, 0)
uniform usampler2D u_b_red, u_b_green, u_b_blue;
uniform int u_count;  // modes over all objects

layout(location = 0) out uvec4 o_y;

void main() {
  int i = fragment_index();
  vec3 acc = vec3(0.0);
  if (i < u_count) {
    ivec4 info = load_int(u_mode_info, i);
    for (int k = 0; k < info.z; ++k) {
      int block = load_int(u_cb_blocks, info.y + k).x;
      acc += dot_rgb(u_vc, info.x + k * GROUPS, u_b_red, u_b_green, u_b_blue, block * GROUPS, GROUPS);
    }
  }
  o_y = store_signal(vec4(acc, 0.0));
}
