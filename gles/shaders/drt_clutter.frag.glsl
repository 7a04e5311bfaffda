// SPDX-License-Identifier: MIT
// DRT §4.3, second half: the clutter atlas, Uc y + Cc c + the clutter's direct light per
// clutter texel (y = Vc b from drt_vc.frag; Cc c: light of other clutter objects' faces, drt.h).
// With NO_DIRECT: the vector clutter's instance (Uc_vec y + Cc_vec c, 4 rows per clutter texel
// in a linear target, no direct light). With GATHER (when some object gathers the real
// radiance): + Gs x_s + Gt x_t (drt_clutter_add_gather, drt_gather.glsl); an object without
// it has empty rows, one with it no Uc modes and no Cc columns.
// Uc and Cc rows are packed four modes / columns per texel.
uniform isampler2D u_texel_map;  // clutter-atlas sized: (clutter texel or -1, first Uc texel, first y, modes)
uniform sampler2D u_uc;
uniform usampler2D u_y;          // per (object, mode), RGB
uniform sampler2D u_direct;      // per clutter texel, RGB (zero when none was given)
uniform isampler2D u_cc_map;     // clutter-atlas sized: (first Cc texel, Cc columns, first column entry, 0)
uniform sampler2D u_cc;
uniform isampler2D u_cc_faces;   // per Cc column: (c index, 0, 0, 0)
uniform usampler2D u_c;          // per clutter face, RGB (drt_c.frag)
#ifdef GATHER
uniform isampler2D u_gather_texels;  // per clutter texel: (first entry, Gs entries, Gt entries, 0)
#endif

layout(location = 0) out OUTPUT_TYPE o_color;

void main() {
  ivec4 map = texelFetch(u_texel_map, ivec2(gl_FragCoord.xy), 0);
  vec3 acc = vec3(0.0);
  if (map.x >= 0) {
    for (int g = 0; 4 * g < map.w; ++g) {
      vec4 w = load(u_uc, map.y + g);
      for (int j = 0; j < 4; ++j) {
        if (4 * g + j >= map.w) break;
        acc += w[j] * load_signal(u_y, map.z + 4 * g + j).rgb;
      }
    }
    ivec4 cc = texelFetch(u_cc_map, ivec2(gl_FragCoord.xy), 0);
    for (int g = 0; 4 * g < cc.y; ++g) {
      vec4 w = load(u_cc, cc.x + g);
      for (int j = 0; j < 4; ++j) {
        if (4 * g + j >= cc.y) break;
        acc += w[j] * load_signal(u_c, load_int(u_cc_faces, cc.z + 4 * g + j).x).rgb;
      }
    }
#ifdef GATHER
    ivec4 row = load_int(u_gather_texels, map.x);
    acc += gather_row(u_xs, row.x, row.y) + gather_row(u_xt, row.x + row.y, row.z);
#endif
#ifndef NO_DIRECT
    acc += load(u_direct, map.x).rgb;
    // A lightmap: clamped at 0 (core's drt_evaluate_clutter_lightmap). The vector instance's
    // OHLSH coefficients are signed and stay as they are.
    acc = max(acc, vec3(0.0));
#endif
  }
  o_color = store_output(vec4(acc, 1.0));
}
