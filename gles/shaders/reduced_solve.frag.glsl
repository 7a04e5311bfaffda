// SPDX-License-Identifier: MIT
// The converged multi-bounce in the reduced space on the GPU (core's reduced_feedback.h; issue
// 20): the iteration x <- c + G x over b-shaped signals, G x = A_i x_i + sum over the slots s
// entering block i of B_s r_s with r = Tb->r x (r.frag and reduce.frag, the runtime's r pass).
// One fragment per (block, group of four modes): fragment i = block * GROUPS + go.
//   STAGE 1 (rhs)      c = P_i b0_i                    (block Jacobi; the plain iteration's c is b0)
//   STAGE 2 (apply)    x' = c + [A_i x_i] + sum_s B_s r_s   (A only for the plain iteration, PLAIN 1)
//   STAGE 3 (residual) one texel: (max |x' - x|, max |x'|) over every mode and channel
//   STAGE 4 (clutter)  u = b0 + s sum over block i's reached samples p of w_p delta_p, the DRT
//                      deltas fed back (core's reduced_clutter_feedback before P): then STAGE 1
//                      of u is c = P b0 + s P t for this step (the plain iteration's c is u)
// The per-channel matrices (P, A: kb x kb; B: kb x kr) are packed in 4 x 4 blocks, one mat4
// per (item, go, gi, channel) in four texels (its columns):
//   texel (((item * GROUPS + go) * COLS + gi) * 3 + channel) * 4 + j = M[4go..4go+3][4gi + j]
// with COLS = GROUPS for P and A, R_GROUPS for B (gles_reduced_solve.cpp, pack_channel_blocks).
uniform int u_count;  // blocks * GROUPS
#if STAGE == 1 || STAGE == 2
// Per block: its modes in groups (common.glsl block_groups); a group past them stays 0 (P, A
// and B have no rows there, b0 and c are 0) and the matrices' columns stop there too.
uniform isampler2D u_block_info;
#endif
#if STAGE == 1 || STAGE == 2 || STAGE == 4
layout(location = 0) out uvec4 o_red;
layout(location = 1) out uvec4 o_green;
layout(location = 2) out uvec4 o_blue;

// acc += M x for the four rows of group go, M's blocks from texel `base` (COLS blocks of 12
// texels), the signal's groups from `s`.
void add_blocks(inout vec4 red, inout vec4 green, inout vec4 blue, sampler2D m, int base, int cols,
                usampler2D x_red, usampler2D x_green, usampler2D x_blue, int s) {
  for (int g = 0; g < cols; ++g) {
    int t = base + g * 12;
    red += mat4(load(m, t), load(m, t + 1), load(m, t + 2), load(m, t + 3)) * load_signal(x_red, s + g);
    green += mat4(load(m, t + 4), load(m, t + 5), load(m, t + 6), load(m, t + 7)) * load_signal(x_green, s + g);
    blue += mat4(load(m, t + 8), load(m, t + 9), load(m, t + 10), load(m, t + 11)) * load_signal(x_blue, s + g);
  }
}
#endif

#if STAGE == 1
uniform sampler2D u_p;
uniform usampler2D u_b0_red, u_b0_green, u_b0_blue;

void main() {
  int i = fragment_index();
  vec4 red = vec4(0.0), green = vec4(0.0), blue = vec4(0.0);
  int block = i / GROUPS;
  int n = i < u_count ? block_groups(load_int(u_block_info, block)) : 0;
  if (i - block * GROUPS < n)
    add_blocks(red, green, blue, u_p, i * GROUPS * 12, n, u_b0_red, u_b0_green, u_b0_blue, block * GROUPS);
  o_red = store_signal(red);
  o_green = store_signal(green);
  o_blue = store_signal(blue);
}

#elif STAGE == 2
uniform sampler2D u_b;             // B_s, R_GROUPS blocks per (slot, go)
uniform isampler2D u_block_slots;  // per block: up to four slots entering it, -1 = none
uniform usampler2D u_c_red, u_c_green, u_c_blue;
uniform usampler2D u_r_red, u_r_green, u_r_blue;
#if PLAIN
uniform sampler2D u_a;
uniform usampler2D u_x_red, u_x_green, u_x_blue;
#endif

void main() {
  int i = fragment_index();
  vec4 red = vec4(0.0), green = vec4(0.0), blue = vec4(0.0);
  int block = i / GROUPS;
  int go = i - block * GROUPS;
  int n = i < u_count ? block_groups(load_int(u_block_info, block)) : 0;
  if (go < n) {
    red = load_signal(u_c_red, i);
    green = load_signal(u_c_green, i);
    blue = load_signal(u_c_blue, i);
#if PLAIN
    add_blocks(red, green, blue, u_a, i * GROUPS * 12, n, u_x_red, u_x_green, u_x_blue, block * GROUPS);
#endif
    ivec4 slots = load_int(u_block_slots, block);
    for (int k = 0; k < 4; ++k) {
      if (slots[k] < 0) break;
      add_blocks(red, green, blue, u_b, ((slots[k] * GROUPS + go) * R_GROUPS) * 12, R_GROUPS, u_r_red, u_r_green,
                 u_r_blue, slots[k] * R_GROUPS);
    }
  }
  o_red = store_signal(red);
  o_green = store_signal(green);
  o_blue = store_signal(blue);
}

#elif STAGE == 4
uniform sampler2D u_w;                // texel (p * GROUPS + go) * 3 + channel: w_p[4go..4go+3][channel]
uniform isampler2D u_block_samples;   // per block: (first reached sample p, count, 0, 0)
uniform isampler2D u_sample_index;    // per reached sample p: (its level sample, 0, 0, 0)
uniform usampler2D u_delta;           // per level sample: dUb b + dUc c (drt_delta.frag)
uniform usampler2D u_b0_red, u_b0_green, u_b0_blue;
uniform float u_scale;                // the damping s

void main() {
  int i = fragment_index();
  vec4 red = vec4(0.0), green = vec4(0.0), blue = vec4(0.0);
  if (i < u_count) {
    int block = i / GROUPS;
    int go = i - block * GROUPS;
    ivec4 range = load_int(u_block_samples, block);
    for (int p = range.x; p < range.x + range.y; ++p) {
      vec3 d = load_signal(u_delta, load_int(u_sample_index, p).x).rgb;
      int t = (p * GROUPS + go) * 3;
      red += load(u_w, t) * d.r;
      green += load(u_w, t + 1) * d.g;
      blue += load(u_w, t + 2) * d.b;
    }
    red = load_signal(u_b0_red, i) + u_scale * red;
    green = load_signal(u_b0_green, i) + u_scale * green;
    blue = load_signal(u_b0_blue, i) + u_scale * blue;
  }
  o_red = store_signal(red);
  o_green = store_signal(green);
  o_blue = store_signal(blue);
}

#else  // STAGE 3
uniform usampler2D u_new_red, u_new_green, u_new_blue;
uniform usampler2D u_old_red, u_old_green, u_old_blue;
layout(location = 0) out uvec4 o_residual;

void main() {
  vec4 change = vec4(0.0), largest = vec4(0.0);
  if (fragment_index() == 0)
    for (int i = 0; i < u_count; ++i) {
      vec4 r = load_signal(u_new_red, i), g = load_signal(u_new_green, i), b = load_signal(u_new_blue, i);
      change = max(change, max(abs(r - load_signal(u_old_red, i)),
                               max(abs(g - load_signal(u_old_green, i)), abs(b - load_signal(u_old_blue, i)))));
      largest = max(largest, max(abs(r), max(abs(g), abs(b))));
    }
  float c = max(max(change.x, change.y), max(change.z, change.w));
  float l = max(max(largest.x, largest.y), max(largest.z, largest.w));
  o_residual = store_signal(vec4(c, l, 0.0, 1.0));
}
#endif
