// SPDX-License-Identifier: MIT
// Direct light of one point or spot light (radiant intensity u_light_rgb, W/sr per channel)
// with an optional cube shadow map; returns E/pi. Shared by the direct-light pass at the proxy
// samples (direct_light.frag, GlesDirectLight) and a renderer's camera image (modrt-demo's
// scene.frag includes it through gles::light_glsl()), so that both see the same light. The
// C++ side sets the uniforms (gles::LightUniforms) and needs "precision highp
// samplerCubeShadow" declared before this file.
uniform vec3 u_light_position;
uniform vec3 u_light_rgb;
uniform float u_light_radius;
uniform vec3 u_spot_direction;  // spot lights: unit axis
uniform vec3 u_spot_cos;        // (cos outer cone, cos inner cone, 1 directional / 0); outer -2 for a point light
uniform mat4 u_shadow_matrix;   // directional lights: world to the orthographic shadow map's clip space
uniform highp samplerCubeShadow u_shadow;
// (near, far, 1 with a shadow map / 0 without, normal offset): the 90° faces' planes, and how
// far (m) the shadow test moves the point along its normal beyond the offset against acne
// (proxy samples that lie inside walls: GpuShadowCube::normal_offset).
uniform vec4 u_shadow_params;
// The ld pass: the texel-footprint floor of the inverse-square falloff, A / (2 pi) for the
// level's smallest block texel area A (modrt/light_policy.h: light_falloff_d2,
// texel_footprint_d2); the camera image shades points, not texels: 0.
uniform float u_falloff_floor_d2;

// Cube-map depth of a point at offset v from the light: the perspective depth of the face
// it projects to (its major axis), as the shadow pass wrote it.
float shadow_depth(vec3 v) {
  float d = max(abs(v.x), max(abs(v.y), abs(v.z)));
  float n = u_shadow_params.x, f = u_shadow_params.y;
  float ndc = (f + n) / (f - n) - (2.0 * f * n) / ((f - n) * d);
  return 0.5 * ndc + 0.5;
}

// A directional light's shadow: an orthographic depth map in the cube's +X face
// (GpuShadowCube::directional_view_proj), read through the direction (1, -v, -u) that lands on
// its texel (u, v) (the cube map's face selection: +X has s = -z / x, t = -y / x).
float directional_visible(vec3 p) {
  vec4 c = u_shadow_matrix * vec4(p, 1.0);
  vec2 uv = clamp(c.xy, vec2(-0.999), vec2(0.999));
  // 1 cm bias along the light, in the map's linear depth (2 / (far - near) per metre).
  float depth = 0.5 * c.z + 0.5 - 0.01 / (u_shadow_params.y - u_shadow_params.x);
  return texture(u_shadow, vec4(1.0, -uv.y, -uv.x, depth));
}

vec3 direct_e_over_pi(vec3 position, vec3 normal) {
  // u_spot_cos.z: 1 for a directional light (u_light_rgb an irradiance, u_spot_direction the
  // direction it travels; no falloff), 0 for a point or spot light.
  bool directional = u_spot_cos.z > 0.5;
  vec3 to_light = directional ? -u_spot_direction : u_light_position - position;
  float d2 = directional ? 1.0 : dot(to_light, to_light);
  vec3 l = to_light * inversesqrt(max(dot(to_light, to_light), 1e-12));
  float cosine = dot(normal, l);
  if (cosine <= 0.0) return vec3(0.0);
  float cone = directional ? 1.0 : smoothstep(u_spot_cos.x, u_spot_cos.y, dot(-l, u_spot_direction));
  if (cone <= 0.0) return vec3(0.0);
  float visible = 1.0;
  if (u_shadow_params.z > 0.0) {
    // Normal offset against acne, scaled with distance (texel footprint grows with it).
    float offset = 0.004 + 0.004 * (directional ? 1.0 : sqrt(d2)) + u_shadow_params.w;
    if (directional) {
      visible = directional_visible(position + normal * offset);
    } else {
      vec3 v = position + normal * offset - u_light_position;
      // A 1 cm bias along the ray, in metres: a constant offset in depth units is d^2 / near
      // times longer in metres (half a metre at 3 m) and lets light through walls.
      vec3 biased = v * max(1.0 - 0.01 / max(length(v), 1e-6), 1e-3);
      visible = texture(u_shadow, vec4(v, shadow_depth(biased)));
    }
  }
  float falloff = directional ? 1.0 : max(max(d2, u_light_radius * u_light_radius), u_falloff_floor_d2);
  return u_light_rgb * (cone * visible * cosine / falloff / 3.14159265);
}
