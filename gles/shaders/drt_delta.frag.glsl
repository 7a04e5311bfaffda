// SPDX-License-Identifier: MIT
// architecture.md §5 step 7 (DRT §4.1, §4.2, §5): the delta dUb b + dUc c of one output item, DELTA_ROWS
// values per item: 1 per level sample (the scalar lightmap; atlas.frag built with DRT 1 adds
// it, padding included), 4 per sample (the OHLSH vector irradiance, dUb_vec / dUc_vec;
// vector.frag adds it) or 9 per probe (SH9, U_dyn; probes.frag adds it). Fragment
// i = item * DELTA_ROWS + j. An item's entries are its b rows (each with the block whose b it
// reads; rows of different objects for the same item and block are summed at creation) and
// its c rows; items no clutter affects have none and write 0.
//   b row: DELTA_ROWS sub-rows of GROUPS texels from entry.x (four modes per texel)
//   c row: DELTA_ROWS sub-rows of ceil(f / 4) texels from entry.x (four faces per texel)
// Built with GATHER (the scalar instance, when some object gathers the real radiance) a
// sample also has gather rows, one per object whose H_sample lists it: Ht x_t - Hs x_s
// (drt_apply_gather), the Hs entries from entry.x and the Ht entries after them
// (drt_gather.glsl).
uniform sampler2D u_dub;
uniform sampler2D u_duc;
uniform isampler2D u_item_entries;  // per item: (first entry, entry count, 0, 0)
// b row: (first texel, source block, 0, 0); c row: (first texel, first face, f, 1); gather
// row: (first entry, Hs entries, Ht entries, 2)
uniform isampler2D u_entries;
uniform usampler2D u_b_red, u_b_green, u_b_blue;
uniform usampler2D u_c;  // per clutter face, RGB
uniform int u_count;     // items * DELTA_ROWS

layout(location = 0) out uvec4 o_delta;

void main() {
  int i = fragment_index();
  vec3 acc = vec3(0.0);
  if (i < u_count) {
    int item = i / DELTA_ROWS;
    int j = i - item * DELTA_ROWS;
    ivec4 range = load_int(u_item_entries, item);
    for (int e = range.x; e < range.x + range.y; ++e) {
      ivec4 entry = load_int(u_entries, e);
      if (entry.w == 0) {
        acc += dot_rgb(u_dub, entry.x + j * GROUPS, u_b_red, u_b_green, u_b_blue, entry.y * GROUPS, GROUPS);
#ifdef GATHER
      } else if (entry.w == 2) {
        acc += gather_row(u_xt, entry.x + entry.y, entry.z) - gather_row(u_xs, entry.x, entry.y);
#endif
      } else {
        int quads = (entry.z + 3) / 4;
        for (int q = 0; q < quads; ++q) {
          vec4 w = load(u_duc, entry.x + j * quads + q);
          for (int k = 0; k < 4; ++k) {
            if (4 * q + k >= entry.z) break;
            acc += w[k] * load_signal(u_c, entry.y + 4 * q + k).rgb;
          }
        }
      }
    }
  }
  o_delta = store_signal(vec4(acc, 0.0));
}
