// SPDX-License-Identifier: MIT
// Step 2 (MRT §4.1, eq. 3), first half: partial sums of b = Td_b ld. One fragment sums
// B_CHUNK samples of one block for four modes and all three channels; fragment
// i = (block * GROUPS + g) * B_CHUNKS + chunk. Splitting the sample sum gives the GPU
// B_CHUNKS times more independent fragments than one per (block, g), which alone would be a
// few hundred long serial loops (b_reduce.frag adds the partials). Td_b is packed four modes
// per RGBA texel: texel (shape * GROUPS + g) * N_MAX + t holds Td_b[4g..4g+3][t].
// LD_IS_SIGNAL selects the ld source: the caller's upload (RGB32F) or the feedback pass's
// output (a signal target).
uniform sampler2D u_td_b;
uniform isampler2D u_block_info;  // per block: (operator set (level.h operator_set), sample_offset, sample_count, quarter turns)
#if LD_IS_SIGNAL
uniform usampler2D u_ld;
vec3 load_ld(int s) { return load_signal(u_ld, s).rgb; }
#else
// The caller's ld: an upload validated on the CPU, or a texture the caller rendered (read
// through sanitize_light).
uniform sampler2D u_ld;
vec3 load_ld(int s) { return sanitize_light(load(u_ld, s).rgb); }
#endif
uniform int u_count;  // blocks * GROUPS * B_CHUNKS

layout(location = 0) out uvec4 o_red;
layout(location = 1) out uvec4 o_green;
layout(location = 2) out uvec4 o_blue;

void main() {
  int i = fragment_index();
  vec4 red = vec4(0.0), green = vec4(0.0), blue = vec4(0.0);
  if (i < u_count) {
    int chunk = i % B_CHUNKS;
    int bg = i / B_CHUNKS;
    int block = bg / GROUPS;
    int g = bg - block * GROUPS;
    ivec4 info = load_int(u_block_info, block);
    int t0 = chunk * B_CHUNK;
    int base = (info.x * GROUPS + g) * N_MAX + t0;
    int first = info.y + t0;
    int n = g < block_groups(info) ? min(B_CHUNK, info.z - t0) : 0;  // past its modes: 0
    for (int k = 0; k < B_CHUNK; ++k) {
      if (k >= n) break;
      vec4 w = load(u_td_b, base + k);
      vec3 l = load_ld(first + k);
      red += w * l.r;
      green += w * l.g;
      blue += w * l.b;
    }
  }
  o_red = store_signal(red);
  o_green = store_signal(green);
  o_blue = store_signal(blue);
}
