// SPDX-License-Identifier: MIT
// Depth of the scene seen from the point light through one cube-map face (90 degree frustum).
uniform mat4 u_view_proj;
uniform vec3 u_offset;  // dynamic meshes: their position this frame; static: 0
layout(location = 0) in vec3 a_position;
void main() { gl_Position = u_view_proj * vec4(a_position + u_offset, 1.0); }
