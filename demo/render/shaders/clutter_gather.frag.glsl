// SPDX-License-Identifier: MIT
// DRT: one clutter mesh object's res x res lightmap texture gathered from the backend's clutter
// atlas on the GPU (nothing read back). u_cell_texel holds, per cell of the object's lightmap
// (padding ring included, as a copy of its neighbour's texel), the clutter atlas texel of its
// clutter texel, or -1 for a cell no chart covers (black).
uniform highp isampler2D u_cell_texel;
uniform sampler2D u_clutter_atlas;
layout(location = 0) out vec4 o_color;

void main() {
  ivec2 a = texelFetch(u_cell_texel, ivec2(gl_FragCoord.xy), 0).xy;
  o_color = a.x < 0 ? vec4(0.0) : vec4(texelFetch(u_clutter_atlas, a, 0).rgb, 1.0);
}
