// SPDX-License-Identifier: MIT
// DRT §4.2, c = Td_c clutter_ld: one fragment per clutter face (the faces of all objects in
// order). Td_c row f is packed four clutter texels per RGBA texel; its clutter_ld are the
// owning object's texels.
uniform sampler2D u_td_c;
uniform isampler2D u_face_info;  // per face: (first Td_c texel, object's first clutter texel, m, 0)
#ifdef FEEDBACK
uniform usampler2D u_clutter_ld;  // per clutter texel, RGB: the light fed back (drt_feedback.frag)
#define CLUTTER_LD(i) load_signal(u_clutter_ld, i).rgb
#else
uniform sampler2D u_clutter_ld;  // per clutter texel, RGB
#define CLUTTER_LD(i) load(u_clutter_ld, i).rgb
#endif
uniform int u_count;             // clutter faces

layout(location = 0) out uvec4 o_c;

void main() {
  int f = fragment_index();
  vec3 acc = vec3(0.0);
  if (f < u_count) {
    ivec4 info = load_int(u_face_info, f);
    for (int q = 0; 4 * q < info.z; ++q) {
      vec4 w = load(u_td_c, info.x + q);
      for (int j = 0; j < 4; ++j) {
        // Texels past the object's last are not read: they belong to the next object.
        if (4 * q + j >= info.z) break;
        acc += w[j] * CLUTTER_LD(info.y + 4 * q + j);
      }
    }
  }
  o_c = store_signal(vec4(acc, 0.0));
}
