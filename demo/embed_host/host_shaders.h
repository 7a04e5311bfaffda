// SPDX-License-Identifier: MIT
// modrt-embed-host's scene mode: the app's own GLSL ES 3.00 shaders. The formulas are the
// usual ones of a lightmapped renderer and the runtime's documented conventions (modrt.h,
// docs/embedding.md): a point light with an inverse-square falloff clamped at its radius and a
// cube shadow map with hardware comparison; outgoing radiance = albedo * (direct E/pi +
// indirect E/pi), the indirect part from the atlas at the proxy mapping's lightmap coordinates,
// from the four OHLSH vector irradiance atlases at the bumped normal in the proxy face's frame,
// from the world-frame SH9 probe texture (bands scaled by A_l/pi) or from the clutter
// lightmap; then exposure, Narkowicz's ACES fit and sRGB. modrt-demo's renderer uses the same
// conventions, so both images of one scene agree (ctest embed_host_scene_matches_demo).
#pragma once

namespace modrt::host {

// Prepended to every shader; LIGHTMAP_BITS is defined by the renderer (1 when the runtime's
// textures are RGBA32UI holding float bits, its fallback without float render targets).
inline const char* const kHeader =
    "#version 300 es\nprecision highp float;\nprecision highp int;\nprecision highp sampler2D;\n"
    "precision highp usampler2D;\nprecision highp isampler2D;\nprecision highp samplerCubeShadow;\n";

inline const char* const kLightmapFetch = R"(
#if LIGHTMAP_BITS
#define LIGHTMAP_SAMPLER usampler2D
vec4 fetch(usampler2D t, ivec2 p) { return uintBitsToFloat(texelFetch(t, p, 0)); }
#else
#define LIGHTMAP_SAMPLER sampler2D
vec4 fetch(sampler2D t, ivec2 p) { return texelFetch(t, p, 0); }
#endif
)";

// The point light: E/pi at a point with normal n, shadowed by the cube map.
inline const char* const kLight = R"(
uniform vec3 u_light_position;
uniform vec3 u_light_rgb;      // radiant intensity per channel, W/sr
uniform float u_light_radius;  // the 1/d^2 clamp
uniform samplerCubeShadow u_shadow;
uniform vec2 u_shadow_planes;  // near, far of the cube faces' 90-degree projections

// The depth the shadow pass wrote for a point at offset v from the light (its cube face is
// the one of its major axis).
float shadow_depth(vec3 v) {
  float d = max(abs(v.x), max(abs(v.y), abs(v.z)));
  float n = u_shadow_planes.x, f = u_shadow_planes.y;
  return 0.5 * ((f + n) / (f - n) - (2.0 * f * n) / ((f - n) * d)) + 0.5;
}

vec3 light_e_over_pi(vec3 position, vec3 normal) {
  vec3 to_light = u_light_position - position;
  float d2 = dot(to_light, to_light);
  vec3 l = to_light * inversesqrt(max(d2, 1e-12));
  float cosine = dot(normal, l);
  if (cosine <= 0.0) return vec3(0.0);
  // Offset along the normal against acne, growing with the distance (the texel footprint).
  vec3 v = position + normal * (0.004 + 0.004 * sqrt(d2)) - u_light_position;
  // A 1 cm bias along the ray in metres (a constant depth offset would be d^2 / near metres).
  float visible = texture(u_shadow, vec4(v, shadow_depth(v * max(1.0 - 0.01 / max(length(v), 1e-6), 1e-3))));
  return u_light_rgb * (visible * cosine / max(d2, u_light_radius * u_light_radius) / 3.14159265);
}
)";

inline const char* const kShadowVert = R"(
uniform mat4 u_view_proj;
uniform vec3 u_offset;
layout(location = 0) in vec3 a_position;
void main() { gl_Position = u_view_proj * vec4(a_position + u_offset, 1.0); }
)";
inline const char* const kShadowFrag = "void main() {}\n";

inline const char* const kFullscreenVert = R"(
void main() {
  vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  gl_Position = vec4(p, 0.0, 1.0);
}
)";

// The clutter's direct light at its texels (positions and normals as RGBA32F images, one texel
// each): clutter_ld = albedo * E/pi, read back for modrt_context_set_clutter_light.
inline const char* const kClutterLightFrag = R"(
uniform sampler2D u_texel_position, u_texel_normal, u_texel_albedo;
layout(location = 0) out vec4 o_color;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec3 e = light_e_over_pi(texelFetch(u_texel_position, p, 0).xyz, texelFetch(u_texel_normal, p, 0).xyz);
  o_color = vec4(texelFetch(u_texel_albedo, p, 0).rgb * e, 1.0);
}
)";

inline const char* const kSceneVert = R"(
uniform mat4 u_view_proj;
uniform vec3 u_offset;
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_tangent;
layout(location = 3) in vec2 a_uv;
layout(location = 4) in vec2 a_lightmap;
layout(location = 5) in vec3 a_face_u;
layout(location = 6) in vec3 a_face_v;
out vec3 v_position;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv;
out vec2 v_lightmap;
out vec3 v_face_u;
out vec3 v_face_v;
void main() {
  v_position = a_position + u_offset;
  v_normal = a_normal;
  v_tangent = a_tangent;
  v_uv = a_uv;
  v_lightmap = a_lightmap;
  v_face_u = a_face_u;
  v_face_v = a_face_v;
  gl_Position = u_view_proj * vec4(v_position, 1.0);
}
)";

// u_kind: 0 a static mesh (atlas, or vector irradiance with a normal map), 1 the dynamic object
// (probes), 2 a clutter mesh (its clutter lightmap), 3 the light's marker (emissive).
inline const char* const kSceneFrag = R"(
uniform int u_kind;
uniform vec3 u_base_color;
uniform int u_has_base_map;
uniform sampler2D u_base_map;
uniform int u_has_normal_map;
uniform float u_normal_scale;
uniform sampler2D u_normal_map;
uniform LIGHTMAP_SAMPLER u_atlas;
uniform LIGHTMAP_SAMPLER u_vector0, u_vector1, u_vector2, u_vector3;
uniform int u_use_vector;
// The probe volume: texel 9 p + k holds radiance SH9 coefficient k of probe p = b g^3 + i +
// g (j + g k) in the world frame (modrt_context_get_probe_texture); the dynamic object's cell:
// block and lower corner (u_probe_cell), trilinear weights (u_probe_f); grid 0: no probes.
uniform LIGHTMAP_SAMPLER u_probes;
uniform int u_probe_grid;
uniform ivec4 u_probe_cell;
uniform vec3 u_probe_f;
// The clutter lightmap: per cell of the object's res x res lightmap, the texel of the runtime's
// clutter atlas it shows (-1: none), and that atlas.
uniform isampler2D u_clutter_cells;
uniform LIGHTMAP_SAMPLER u_clutter_atlas;
in vec3 v_position;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
in vec2 v_lightmap;
in vec3 v_face_u;
in vec3 v_face_v;
layout(location = 0) out vec4 o_color;

// Bilinear over texelFetch (float32 textures need not be filterable in ES 3.0).
vec4 bilinear(LIGHTMAP_SAMPLER t, vec2 texel) {
  vec2 p = texel - 0.5;
  ivec2 i = ivec2(floor(p));
  vec2 f = p - vec2(i);
  vec4 a = mix(fetch(t, i), fetch(t, i + ivec2(1, 0)), f.x);
  vec4 b = mix(fetch(t, i + ivec2(0, 1)), fetch(t, i + ivec2(1, 1)), f.x);
  return mix(a, b, f.y);
}

vec4 clutter_cell(ivec2 c) {
  ivec2 a = texelFetch(u_clutter_cells, c, 0).xy;
  return a.x < 0 ? vec4(0.0) : fetch(u_clutter_atlas, a);
}

vec3 clutter_lightmap(vec2 texel) {
  vec2 p = texel - 0.5;
  ivec2 hi = textureSize(u_clutter_cells, 0) - 1;
  ivec2 i = ivec2(floor(p));
  vec2 f = p - vec2(i);
  ivec2 i0 = clamp(i, ivec2(0), hi), i1 = clamp(i + 1, ivec2(0), hi);
  vec4 a = mix(clutter_cell(i0), clutter_cell(ivec2(i1.x, i0.y)), f.x);
  vec4 b = mix(clutter_cell(ivec2(i0.x, i1.y)), clutter_cell(i1), f.x);
  return max(mix(a, b, f.y).rgb, vec3(0.0));
}

vec3 probe_coefficient(int p, int k) {
  int i = 9 * p + k;
  int w = textureSize(u_probes, 0).x;
  return fetch(u_probes, ivec2(i % w, i / w)).rgb;
}

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
  if (g == 0) return e;
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
  if (u_kind == 3) {
    o_color = vec4(u_light_rgb * 20.0, 1.0);
    return;
  }
  vec3 n = normalize(v_normal);
  if (!gl_FrontFacing) n = -n;
  vec3 shading_n = n;
  if (u_has_normal_map != 0) {
    vec3 t = normalize(v_tangent.xyz - n * dot(n, v_tangent.xyz));
    vec3 b = cross(n, t) * v_tangent.w;
    vec3 m = texture(u_normal_map, v_uv).xyz * 2.0 - 1.0;
    m.xy *= u_normal_scale;
    shading_n = normalize(mat3(t, b, n) * m);
  }
  vec3 direct = light_e_over_pi(v_position, shading_n);
  vec3 indirect;
  if (u_kind == 1) {
    indirect = probe_e_over_pi(shading_n);
  } else if (u_kind == 2) {
    indirect = clutter_lightmap(v_lightmap);
  } else if (u_use_vector != 0) {
    // OHLSH coefficients in the proxy face's frame (u, v, inward normal): E/pi at the bumped
    // normal = sum_i c_i ohlsh_i(n) (modrt_context_get_vector_textures).
    vec3 fu = normalize(v_face_u), fv = normalize(v_face_v);
    vec3 fn = cross(fu, fv);
    vec3 nf = vec3(dot(shading_n, fu), dot(shading_n, fv), dot(shading_n, fn));
    nf.z = max(nf.z, 0.0);
    nf = normalize(nf);
    indirect = 0.282095 * bilinear(u_vector0, v_lightmap).rgb + 0.488603 * nf.y * bilinear(u_vector1, v_lightmap).rgb +
               0.488603 * nf.z * bilinear(u_vector2, v_lightmap).rgb + 0.488603 * nf.x * bilinear(u_vector3, v_lightmap).rgb;
    indirect = max(indirect, vec3(0.0));
  } else {
    indirect = max(bilinear(u_atlas, v_lightmap).rgb, vec3(0.0));
  }
  vec3 albedo = u_base_color;
  if (u_has_base_map != 0) {
    vec3 c = texture(u_base_map, v_uv).rgb;
    albedo *= mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(vec3(0.04045), c));
  }
  o_color = vec4(albedo * (direct + indirect), 1.0);
}
)";

inline const char* const kTonemapFrag = R"(
uniform sampler2D u_linear;
uniform float u_exposure;
layout(location = 0) out vec4 o_color;
vec3 srgb(vec3 c) { return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c)); }
void main() {
  vec3 x = texelFetch(u_linear, ivec2(gl_FragCoord.xy), 0).rgb * u_exposure;
  vec3 mapped = clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
  o_color = vec4(srgb(mapped), 1.0);
}
)";

}  // namespace modrt::host
