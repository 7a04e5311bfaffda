// SPDX-License-Identifier: MIT
// The probe volume in the world frame, for a renderer to sample on the GPU (C API
// modrt_context_get_probe_texture): each probe's radiance SH9 rotated from its block's
// canonical frame by the block's quarter turns, c_world = M_turns c (core's
// sh9_quarter_turn_rotation, the CPU's ProbeSampler::world_probes). Fragment i = (block g^3 +
// probe) 9 + k, the layout of probes.frag.
uniform OUTPUT_SAMPLER u_probes;  // probes.frag's target
uniform sampler2D u_rotation;     // R32F, 81 x 4: M_turns row-major in row `turns`
uniform isampler2D u_block_info;  // per block: (operator set (level.h operator_set), sample_offset, sample_count, quarter turns)
uniform int u_count;              // blocks * PROBE_ROWS

layout(location = 0) out OUTPUT_TYPE o_sh;

void main() {
  int i = fragment_index();
  vec3 acc = vec3(0.0);
  if (i < u_count) {
    int block = i / PROBE_ROWS;
    int k = i % 9;
    int first = i - k;
    int turns = load_int(u_block_info, block).w & 3;
    for (int j = 0; j < 9; ++j)
      acc += texelFetch(u_rotation, ivec2(9 * k + j, turns), 0).r * load_output_2d(u_probes, lin(first + j)).rgb;
  }
  o_sh = store_output(vec4(acc, 1.0));
}
