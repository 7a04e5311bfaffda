// SPDX-License-Identifier: MIT
// Steps 3, 5 and 6 in one pass over the padded lightmap atlas (MRT §6.2–6.3):
// texel = Ub b (own block) + sum over the block's response slots of Ur r. Padding texels
// (architecture.md §4) evaluate the sample they copy, so padding costs no separate pass and no
// read-after-write of the atlas. Ub is packed four modes per texel: texel
// (shape * n_max + t) * groups + g = Ub[t][4g..4g+3]; Ur likewise with r_groups.
uniform sampler2D u_ub;
uniform sampler2D u_ur;
uniform isampler2D u_texel_sample;  // atlas-sized: sample whose value the texel shows, or -1
uniform isampler2D u_sample_info;   // per sample: (block, local index t, atlas x, atlas y)
uniform isampler2D u_sample_slots;  // per sample: up to four response slots, -1 = none
uniform isampler2D u_sample_rows;   // per sample: the Ur row of each of those slots
uniform isampler2D u_block_info;    // per block: (operator set (level.h operator_set), sample_offset, sample_count, quarter turns)
uniform usampler2D u_b_red, u_b_green, u_b_blue;
uniform usampler2D u_r_red, u_r_green, u_r_blue;
#if DRT
uniform usampler2D u_delta;  // per sample: dUb b + dUc c (drt_delta.frag), RGB
#endif
layout(location = 0) out OUTPUT_TYPE o_color;

void main() {
  int s = texelFetch(u_texel_sample, ivec2(gl_FragCoord.xy), 0).x;
  vec3 acc = vec3(0.0);
  if (s >= 0) {
    ivec4 info = load_int(u_sample_info, s);
    ivec4 block = load_int(u_block_info, info.x);
    acc = dot_rgb_b(u_ub, (block.x * N_MAX + info.y) * GROUPS, u_b_red, u_b_green, u_b_blue, info.x * GROUPS,
                    block_groups(block));
    ivec4 slots = load_int(u_sample_slots, s);
    ivec4 rows = load_int(u_sample_rows, s);
    for (int k = 0; k < 4; ++k) {
      if (slots[k] < 0) break;
      acc += dot_rgb(u_ur, rows[k] * R_GROUPS, u_r_red, u_r_green, u_r_blue, slots[k] * R_GROUPS, R_GROUPS);
    }
#if DRT
    // architecture.md §5 step 7, after steps 3 and 5 as in core: the level lightmap is clamped first
    // (level_compute_lightmap), the corrected one again (drt_apply).
    acc = max(acc, vec3(0.0)) + load_signal(u_delta, s).rgb;
#endif
  }
  // The lightmap policy (core reference_runtime.h): max(lightmap, 0), never a negative texel.
  o_color = store_output(vec4(max(acc, vec3(0.0)), 1.0));
}
