// SPEC §5 step 7 (DRT §4.1, §4.2): the lightmap delta dUb b + dUc c of one level sample, one
// fragment per sample; atlas.frag (built with DRT 1) adds it to every texel showing the sample,
// padding included. A sample's entries are its dUb rows (each with the block whose b it reads)
// and dUc rows over all objects; samples no clutter affects have none and write 0.
//   dUb row k: GROUPS texels from k * GROUPS (four modes per texel)
//   dUc row:   four faces per texel, ceil(f / 4) texels
uniform sampler2D u_dub;
uniform sampler2D u_duc;
uniform isampler2D u_sample_entries;  // per sample: (first entry, entry count, 0, 0)
uniform isampler2D u_entries;         // dUb: (first texel, source block, 0, 0); dUc: (first texel, first face, f, 1)
uniform usampler2D u_b_red, u_b_green, u_b_blue;
uniform usampler2D u_c;  // per clutter face, RGB
uniform int u_count;     // level samples

layout(location = 0) out uvec4 o_delta;

void main() {
  int s = fragment_index();
  vec3 acc = vec3(0.0);
  if (s < u_count) {
    ivec4 range = load_int(u_sample_entries, s);
    for (int e = range.x; e < range.x + range.y; ++e) {
      ivec4 entry = load_int(u_entries, e);
      if (entry.w == 0) {
        acc += dot_rgb(u_dub, entry.x, u_b_red, u_b_green, u_b_blue, entry.y * GROUPS, GROUPS);
      } else {
        for (int q = 0; 4 * q < entry.z; ++q) {
          vec4 w = load(u_duc, entry.x + q);
          for (int j = 0; j < 4; ++j) {
            if (4 * q + j >= entry.z) break;
            acc += w[j] * load_signal(u_c, entry.y + 4 * q + j).rgb;
          }
        }
      }
    }
  }
  o_delta = store_signal(vec4(acc, 0.0));
}
