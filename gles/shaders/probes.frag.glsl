// SPDX-License-Identifier: MIT
// Step 9 (MRT §6.5): volume probes, radiance SH9 per probe. Fragment i = block * rows + row
// (row = 9 p + j): Ubvol b of the block itself plus, for each slot entering the block, the
// probe response turned onto the slot's entry face times r. Both operators are packed four
// modes per texel: Ubvol texel (shape * rows + row) * groups + g, response texel
// (face * rows + row) * r_groups + g.
uniform sampler2D u_ubvol;
uniform sampler2D u_probe_response;
uniform isampler2D u_block_info;   // per block: (operator set (level.h operator_set), sample_offset, sample_count, quarter turns)
uniform isampler2D u_block_slots;  // per block: up to four slots entering it, -1 = none
uniform isampler2D u_slot_info;    // per slot: (first record, record count, block, entry face)
uniform usampler2D u_b_red, u_b_green, u_b_blue;
uniform usampler2D u_r_red, u_r_green, u_r_blue;
uniform int u_count;  // blocks * PROBE_ROWS
#if DRT
uniform usampler2D u_probe_delta;  // per probe coefficient: Udyn b + Udyn_c c (drt_delta.frag)
#endif

layout(location = 0) out OUTPUT_TYPE o_sh;

void main() {
  int i = fragment_index();
  vec3 acc = vec3(0.0);
  if (i < u_count) {
    int block = i / PROBE_ROWS;
    int row = i - block * PROBE_ROWS;
    ivec4 binfo = load_int(u_block_info, block);
    acc = dot_rgb_b(u_ubvol, (binfo.x * PROBE_ROWS + row) * GROUPS, u_b_red, u_b_green, u_b_blue, block * GROUPS,
                    block_groups(binfo));
    ivec4 slots = load_int(u_block_slots, block);
    for (int k = 0; k < 4; ++k) {
      if (slots[k] < 0) break;
      int face = load_int(u_slot_info, slots[k]).w;
      acc += dot_rgb(u_probe_response, (face * PROBE_ROWS + row) * R_GROUPS, u_r_red, u_r_green, u_r_blue,
                     slots[k] * R_GROUPS, R_GROUPS);
    }
#if DRT
    acc += load_signal(u_probe_delta, i).rgb;  // i = 9 (global probe) + j, U_dyn's layout
#endif
  }
  o_sh = store_output(vec4(acc, 1.0));
}
