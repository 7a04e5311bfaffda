// SPDX-License-Identifier: MIT
// Shared by every modrt pass. The C++ side puts "#version 300 es" and these defines first:
//   LINEAR_SHIFT      log2 of the width of every linear-layout texture (see gles/README.md)
//   GROUPS, R_GROUPS  ceil(kb / 4), ceil(kr / 4): mode groups of four
//   N_MAX             the largest shape's sample count
//   PROBE_ROWS        9 g^3, rows of Ubvol (0 without probes)
//   VECTOR_ROWS       4 x (dead-end samples), rows of each turned Ur_vec (0 without vector irradiance)
//   B_CHUNK, B_CHUNKS samples per partial sum of b, and partial sums per block (b.frag)
// Sizes are compile-time constants, not uniforms, so that loops have constant trip counts the
// compiler can unroll and software-pipeline (the passes are texture-latency bound).
//   OUTPUT_BITS       1: the atlas and probes are RGBA32UI targets holding float bit patterns
//                     (TargetFormat::bits32); 0: RGBA32F or RGBA16F targets.
//   OUTPUT_MAX        the target's largest finite value (65504 for RGBA16F, FLT_MAX otherwise):
//                     store_output saturates there instead of writing Inf.
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp isampler2D;
precision highp usampler2D;

#define LINEAR_WIDTH (1 << LINEAR_SHIFT)

// Long 1D arrays are stored row by row in 2D textures LINEAR_WIDTH texels wide.
ivec2 lin(int i) { return ivec2(i & (LINEAR_WIDTH - 1), i >> LINEAR_SHIFT); }

// Index of this fragment in a linear-layout render target.
int fragment_index() { return (int(gl_FragCoord.y) << LINEAR_SHIFT) + int(gl_FragCoord.x); }

// Intermediate signals (b, r, feedback ld) are RGBA32UI textures holding float bit
// patterns: exact float32, renderable in every ES 3.0 context, and never filtered.
vec4 load_signal(usampler2D t, int i) { return uintBitsToFloat(texelFetch(t, lin(i), 0)); }
uvec4 store_signal(vec4 v) { return floatBitsToUint(v); }

// Outputs a renderer samples (atlas, probes) use the runtime's TargetFormat; every value is
// finite (saturated at +-OUTPUT_MAX, e.g. a float16 target's 65504, never Inf).
#if OUTPUT_BITS
#define OUTPUT_SAMPLER usampler2D
#define OUTPUT_TYPE uvec4
vec4 load_output_2d(usampler2D t, ivec2 p) { return uintBitsToFloat(texelFetch(t, p, 0)); }
OUTPUT_TYPE store_output(vec4 v) { return floatBitsToUint(clamp(v, vec4(-OUTPUT_MAX), vec4(OUTPUT_MAX))); }
#else
#define OUTPUT_SAMPLER sampler2D
#define OUTPUT_TYPE vec4
vec4 load_output_2d(sampler2D t, ivec2 p) { return texelFetch(t, p, 0); }
OUTPUT_TYPE store_output(vec4 v) { return clamp(v, vec4(-OUTPUT_MAX), vec4(OUTPUT_MAX)); }
#endif

vec4 load(sampler2D t, int i) { return texelFetch(t, lin(i), 0); }

// Light the caller rendered on the GPU (GlesLevelRuntime::update_from_texture), which nothing
// validated: NaN and negative values read as 0 and values above MAX_LIGHT (kMaxLightValue) as
// MAX_LIGHT, so a light inside a wall cannot poison the frame. A validated upload is unchanged.
vec3 sanitize_light(vec3 l) { return clamp(mix(l, vec3(0.0), isnan(l)), 0.0, MAX_LIGHT); }
ivec4 load_int(isampler2D t, int i) { return texelFetch(t, lin(i), 0); }

// One packed operator row times a three-plane signal, per channel: the sum over `groups`
// texels of dot(op[u + g], signal[s + g]). Called with GROUPS or R_GROUPS, constants that the
// compiler unrolls once it has inlined the call.
vec3 dot_rgb(sampler2D op, int u, usampler2D red, usampler2D green, usampler2D blue, int s, int groups) {
  vec3 acc = vec3(0.0);
  for (int g = 0; g < groups; ++g) {
    vec4 w = load(op, u + g);
    acc += vec3(dot(w, load_signal(red, s + g)), dot(w, load_signal(green, s + g)),
                dot(w, load_signal(blue, s + g)));
  }
  return acc;
}
// A block's modes in groups of four: its operator set's kb (level.h block_kb), at most GROUPS
// (b's stride); packed above the quarter turns in the block table's w.
int block_groups(ivec4 block_info) { return block_info.w >> 2; }
// Only where b exists (the level runtime's passes; the direct-light pass has none).
#ifdef GROUPS
// dot_rgb over the first `n` of a b row's GROUPS groups (the rest of a block's b is zero, its
// operators' too): a cube block beside a shaped set with more modes costs its own modes.
vec3 dot_rgb_b(sampler2D op, int u, usampler2D red, usampler2D green, usampler2D blue, int s, int n) {
  vec3 acc = vec3(0.0);
  for (int g = 0; g < GROUPS; ++g) {
    if (g >= n) break;
    vec4 w = load(op, u + g);
    acc += vec3(dot(w, load_signal(red, s + g)), dot(w, load_signal(green, s + g)),
                dot(w, load_signal(blue, s + g)));
  }
  return acc;
}
#endif
