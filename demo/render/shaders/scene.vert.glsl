// SPDX-License-Identifier: MIT
// The camera image: every mesh, static ones with their lightmap coordinates (proxy mapping,
// MRT §7.2), dynamic ones moved by u_offset.
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
