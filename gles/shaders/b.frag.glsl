// Step 2 (MRT §4.1, eq. 3): b = Td_b ld per block. One fragment computes four modes of one
// block for all three channels; fragment i = block * groups + g. Td_b rows are packed four
// modes per RGBA texel: texel (shape * groups + g) * n_max + t holds Td_b[4g..4g+3][t].
// LD_IS_SIGNAL selects the ld source: the caller's upload (RGB32F) or the feedback pass's
// output (a signal target).
uniform sampler2D u_td_b;
uniform isampler2D u_block_info;  // per block: (shape, sample_offset, sample_count, 0)
#if LD_IS_SIGNAL
uniform usampler2D u_ld;
vec3 load_ld(int s) { return load_signal(u_ld, s).rgb; }
#else
uniform sampler2D u_ld;
vec3 load_ld(int s) { return load(u_ld, s).rgb; }
#endif
uniform int u_count;   // blocks * groups
uniform int u_groups;  // ceil(kb / 4)
uniform int u_n_max;   // largest shape sample count

layout(location = 0) out uvec4 o_red;
layout(location = 1) out uvec4 o_green;
layout(location = 2) out uvec4 o_blue;

void main() {
  int i = fragment_index();
  vec4 red = vec4(0.0), green = vec4(0.0), blue = vec4(0.0);
  if (i < u_count) {
    int block = i / u_groups;
    int g = i - block * u_groups;
    ivec4 info = load_int(u_block_info, block);
    int base = (info.x * u_groups + g) * u_n_max;
    for (int t = 0; t < info.z; ++t) {
      vec4 w = load(u_td_b, base + t);
      vec3 l = load_ld(info.y + t);
      red += w * l.r;
      green += w * l.g;
      blue += w * l.b;
    }
  }
  o_red = store_signal(red);
  o_green = store_signal(green);
  o_blue = store_signal(blue);
}
