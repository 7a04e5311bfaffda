// SPDX-License-Identifier: MIT
// Step 9, vector irradiance (MRT §6.4, App. B): the four OHLSH coefficients of E/pi, in the
// sample's face frame, for every atlas texel, one coefficient per colour attachment (RGB in
// .rgb). As atlas.frag: Ub_vec b of the texel's own block plus, for each response slot
// entering it, the Ur_vec turned onto the slot's entry face (Level::vector_response) times
// r; padding texels evaluate the sample they copy. Packing, four modes per texel:
//   Ub_vec   texel ((shape * N_MAX + t) * 4 + i) * GROUPS + g   = Ub_vec[4t + i][4g..4g+3]
//   response texel ((face * VECTOR_ROWS + 4 row + i) * R_GROUPS + g)
uniform sampler2D u_ub_vec;
uniform sampler2D u_vector_response;
uniform isampler2D u_texel_sample;  // atlas-sized: sample whose value the texel shows, or -1
uniform isampler2D u_sample_info;   // per sample: (block, local index t, atlas x, atlas y)
uniform isampler2D u_sample_slots;  // per sample: up to four response slots, -1 = none
uniform isampler2D u_sample_rows;   // per sample: the dead-end row of each of those slots
uniform isampler2D u_block_info;    // per block: (operator set (level.h operator_set), sample_offset, sample_count, quarter turns)
uniform isampler2D u_slot_info;     // per slot: (first record, record count, block, entry face)
uniform usampler2D u_b_red, u_b_green, u_b_blue;
uniform usampler2D u_r_red, u_r_green, u_r_blue;
#if DRT
uniform usampler2D u_vector_delta;  // per sample and coefficient: dUb_vec b + dUc_vec c (drt_delta.frag)
#endif
layout(location = 0) out OUTPUT_TYPE o_a0;
layout(location = 1) out OUTPUT_TYPE o_a1;
layout(location = 2) out OUTPUT_TYPE o_a2;
layout(location = 3) out OUTPUT_TYPE o_a3;

void main() {
  int s = texelFetch(u_texel_sample, ivec2(gl_FragCoord.xy), 0).x;
  vec3 a[4] = vec3[4](vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0));
  if (s >= 0) {
    ivec4 info = load_int(u_sample_info, s);
    ivec4 block = load_int(u_block_info, info.x);
    for (int i = 0; i < 4; ++i)
      a[i] = dot_rgb_b(u_ub_vec, ((block.x * N_MAX + info.y) * 4 + i) * GROUPS, u_b_red, u_b_green, u_b_blue,
                       info.x * GROUPS, block_groups(block));
    ivec4 slots = load_int(u_sample_slots, s);
    ivec4 rows = load_int(u_sample_rows, s);
    for (int k = 0; k < 4; ++k) {
      if (slots[k] < 0) break;
      int face = load_int(u_slot_info, slots[k]).w;
      int first = face * VECTOR_ROWS + 4 * rows[k];
      for (int i = 0; i < 4; ++i)
        a[i] += dot_rgb(u_vector_response, (first + i) * R_GROUPS, u_r_red, u_r_green, u_r_blue,
                        slots[k] * R_GROUPS, R_GROUPS);
    }
#if DRT
    for (int i = 0; i < 4; ++i) a[i] += load_signal(u_vector_delta, 4 * s + i).rgb;
#endif
  }
  o_a0 = store_output(vec4(a[0], 1.0));
  o_a1 = store_output(vec4(a[1], 1.0));
  o_a2 = store_output(vec4(a[2], 1.0));
  o_a3 = store_output(vec4(a[3], 1.0));
}
