// SPDX-License-Identifier: MIT
// Step 4 (MRT §6.3): r = Tb->r b, the records of each response slot summed. One fragment
// computes the part of four response modes of one slot that comes from four b modes, over
// all the slot's records; fragment i = (slot * R_GROUPS + go) * GROUPS + gi, and
// reduce.frag adds the GROUPS parts (GROUPS times more parallel fragments). Record j's
// kr x kb matrix T is stored in 4x4 blocks, one mat4 per (go, gi) in four texels:
// texel ((j * r_groups + go) * groups + gi) * 4 + c = T[4go..4go+3][4gi + c].
uniform sampler2D u_t;
uniform isampler2D u_slot_info;     // per slot: (first record, record count, block, entry face)
uniform isampler2D u_record_block;  // per record: (source block, its groups of modes, 0, 0)
uniform usampler2D u_b_red, u_b_green, u_b_blue;
uniform int u_count;  // slots * R_GROUPS * GROUPS

layout(location = 0) out uvec4 o_red;
layout(location = 1) out uvec4 o_green;
layout(location = 2) out uvec4 o_blue;

void main() {
  int i = fragment_index();
  vec4 red = vec4(0.0), green = vec4(0.0), blue = vec4(0.0);
  if (i < u_count) {
    int gi = i % GROUPS;
    int so = i / GROUPS;
    int slot = so / R_GROUPS;
    int go = so - slot * R_GROUPS;
    ivec4 info = load_int(u_slot_info, slot);
    for (int j = info.x; j < info.x + info.y; ++j) {
      ivec4 record = load_int(u_record_block, j);
      if (gi >= record.y) continue;  // past the source block's modes: T and b are zero there
      int source = record.x * GROUPS + gi;
      int t = ((j * R_GROUPS + go) * GROUPS + gi) * 4;
      mat4 m = mat4(load(u_t, t), load(u_t, t + 1), load(u_t, t + 2), load(u_t, t + 3));
      red += m * load_signal(u_b_red, source);
      green += m * load_signal(u_b_green, source);
      blue += m * load_signal(u_b_blue, source);
    }
  }
  o_red = store_signal(red);
  o_green = store_signal(green);
  o_blue = store_signal(blue);
}
