// SPDX-License-Identifier: MIT
// Shading: outgoing radiance = albedo * (direct E/pi + indirect E/pi). Indirect E/pi comes
// from the lightmap atlas (bilinear over texelFetch: float32 textures need not be
// filterable in ES 3.0), or for normal-mapped surfaces from the four OHLSH vector irradiance
// atlases evaluated at the bumped normal in the proxy face's frame (MRT §6.4), or for
// dynamic meshes from the probe volume's SH9 (MRT §6.5), sampled here from the backend's
// world-frame probe texture (nothing read back). u_output: 0 combined, 1 direct, 2 indirect.
// Direct light: direct_e_over_pi_all, the sum over the frame's lights of light.glsl's model
// (the renderer includes one renamed copy per light before this file). Back faces (drawn only for
// double-sided materials) are shaded with the normal turned and the tangent frame mirrored, so
// that the bumped normal turns too (glTF's double-sided lighting).
uniform vec3 u_base_color;
uniform int u_has_base_map;
uniform sampler2D u_base_map;  // sRGB-encoded RGBA8, multiplies u_base_color
uniform int u_has_normal_map;
uniform float u_normal_scale;
uniform sampler2D u_normal_map;
uniform sampler2D u_atlas;
uniform sampler2D u_vector0, u_vector1, u_vector2, u_vector3;
uniform int u_use_vector;
uniform int u_dynamic;
// The probe volume in the world frame: texel 9 p + k is radiance SH9 coefficient k of probe
// p = b g^3 + i + g (j + g k) (Backend::world_probe_texture's layout, row-major at its width);
// u_probe_grid 0: no probe volume.
// The dynamic object's cell (ProbeSampler::locate at its position): u_probe_cell = (block,
// lower corner on that block's g^3 grid), u_probe_f its trilinear weights.
uniform sampler2D u_probes;
uniform int u_probe_grid;
uniform ivec4 u_probe_cell;
uniform vec3 u_probe_f;
uniform int u_output;
uniform int u_emissive;       // a light's own marker, drawn in u_marker_rgb x 20
uniform vec3 u_marker_rgb;
uniform int u_clutter;        // DRT clutter mesh: u_atlas is its own clutter lightmap
in vec3 v_position;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
in vec2 v_lightmap;
in vec3 v_face_u;
in vec3 v_face_v;
layout(location = 0) out vec4 o_color;

vec4 bilinear(sampler2D t, vec2 texel) {
  vec2 p = texel - 0.5;
  ivec2 i = ivec2(floor(p));
  vec2 f = p - vec2(i);
  vec4 a = mix(texelFetch(t, i, 0), texelFetch(t, i + ivec2(1, 0), 0), f.x);
  vec4 b = mix(texelFetch(t, i + ivec2(0, 1), 0), texelFetch(t, i + ivec2(1, 1), 0), f.x);
  return mix(a, b, f.y);
}

vec3 probe_coefficient(int p, int k) {
  int i = 9 * p + k;
  int w = textureSize(u_probes, 0).x;
  return texelFetch(u_probes, ivec2(i % w, i / w), 0).rgb;
}

// E/pi at world normal n: the trilinear mix of the cell's 8 probes, radiance bands scaled by
// A_l / pi = 1, 2/3, 1/4 (core's irradiance_from_radiance_sh9), as ProbeSampler::sample.
vec3 probe_e_over_pi(vec3 n) {
  float y[9];
  y[0] = 0.282095;
  y[1] = 0.488603 * n.y * (2.0 / 3.0);
  y[2] = 0.488603 * n.z * (2.0 / 3.0);
  y[3] = 0.488603 * n.x * (2.0 / 3.0);
  y[4] = 1.092548 * n.x * n.y * 0.25;
  y[5] = 1.092548 * n.y * n.z * 0.25;
  y[6] = 0.315392 * (3.0 * n.z * n.z - 1.0) * 0.25;
  y[7] = 1.092548 * n.x * n.z * 0.25;
  y[8] = 0.546274 * (n.x * n.x - n.y * n.y) * 0.25;
  int g = u_probe_grid;
  vec3 e = vec3(0.0);
  if (g == 0) return e;  // no probe volume
  for (int c = 0; c < 8; ++c) {
    ivec3 o = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    vec3 t = mix(vec3(1.0) - u_probe_f, u_probe_f, vec3(o));
    float w = t.x * t.y * t.z;
    if (w == 0.0) continue;
    ivec3 q = min(u_probe_cell.yzw + o, ivec3(g - 1));
    int p = u_probe_cell.x * g * g * g + q.x + g * (q.y + g * q.z);
    for (int k = 0; k < 9; ++k) e += w * y[k] * probe_coefficient(p, k);
  }
  return max(e, vec3(0.0));
}

void main() {
  if (u_emissive != 0) {
    o_color = vec4(u_marker_rgb * 20.0, 1.0);
    return;
  }
  vec3 n = normalize(v_normal);
  vec4 tangent = v_tangent;
  if (!gl_FrontFacing) {
    n = -n;
    tangent = -tangent;  // t and b = cross(n, t) w both turn
  }
  vec3 shading_n = n;
  if (u_has_normal_map != 0) {
    vec3 t = normalize(tangent.xyz - n * dot(n, tangent.xyz));
    vec3 b = cross(n, t) * tangent.w;
    vec3 m = texture(u_normal_map, v_uv).xyz * 2.0 - 1.0;
    m.xy *= u_normal_scale;
    shading_n = normalize(mat3(t, b, n) * m);
  }
  vec3 direct = direct_e_over_pi_all(v_position, shading_n);
  vec3 indirect;
  if (u_dynamic != 0) {
    indirect = probe_e_over_pi(shading_n);
  } else if (u_clutter != 0) {
    // The clutter lightmap (Cb b + Cc c, E/pi) at the mesh's lightmap UVs; taps clamped to
    // the texture (a chart may touch the atlas edge).
    vec2 p = v_lightmap - 0.5;
    ivec2 hi = textureSize(u_atlas, 0) - 1;
    ivec2 i = ivec2(floor(p));
    vec2 f = p - vec2(i);
    ivec2 i0 = clamp(i, ivec2(0), hi), i1 = clamp(i + 1, ivec2(0), hi);
    vec4 a = mix(texelFetch(u_atlas, i0, 0), texelFetch(u_atlas, ivec2(i1.x, i0.y), 0), f.x);
    vec4 b = mix(texelFetch(u_atlas, ivec2(i0.x, i1.y), 0), texelFetch(u_atlas, i1, 0), f.x);
    indirect = max(mix(a, b, f.y).rgb, vec3(0.0));
  } else if (u_use_vector != 0) {
    // The OHLSH coefficients are in the proxy face frame (u, v, inward normal).
    vec3 fu = normalize(v_face_u), fv = normalize(v_face_v);
    vec3 fn = cross(fu, fv);
    vec3 nf = vec3(dot(shading_n, fu), dot(shading_n, fv), dot(shading_n, fn));
    nf.z = max(nf.z, 0.0);  // OHLSH is defined over the face's hemisphere
    nf = normalize(nf);
    indirect = 0.282095 * bilinear(u_vector0, v_lightmap).rgb + 0.488603 * nf.y * bilinear(u_vector1, v_lightmap).rgb +
               0.488603 * nf.z * bilinear(u_vector2, v_lightmap).rgb + 0.488603 * nf.x * bilinear(u_vector3, v_lightmap).rgb;
    indirect = max(indirect, vec3(0.0));
  } else {
    indirect = max(bilinear(u_atlas, v_lightmap).rgb, vec3(0.0));
  }
  vec3 e = u_output == 1 ? direct : u_output == 2 ? indirect : direct + indirect;
  vec3 albedo = u_base_color;
  if (u_has_base_map != 0) {
    vec3 c = texture(u_base_map, v_uv).rgb;
    albedo *= mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(vec3(0.04045), c));
  }
  o_color = vec4(albedo * e, 1.0);
}
