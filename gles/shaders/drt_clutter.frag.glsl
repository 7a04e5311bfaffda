// DRT §4.3, second half: the clutter atlas, Uc y + the clutter's direct light per clutter
// texel (y = Vc b from drt_vc.frag). Uc row t is packed four modes per texel.
uniform isampler2D u_texel_map;  // clutter-atlas sized: (clutter texel or -1, first Uc texel, first y, modes)
uniform sampler2D u_uc;
uniform usampler2D u_y;          // per (object, mode), RGB
uniform sampler2D u_direct;      // per clutter texel, RGB (zero when none was given)

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
    acc += load(u_direct, map.x).rgb;
  }
  o_color = store_output(vec4(acc, 1.0));
}
