// SPDX-License-Identifier: MIT
// Linear radiance -> display: exposure, a filmic curve (Narkowicz's ACES fit), sRGB encoding.
uniform sampler2D u_linear;
uniform float u_exposure;
layout(location = 0) out vec4 o_color;
vec3 srgb(vec3 c) {
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}
void main() {
  vec3 x = texelFetch(u_linear, ivec2(gl_FragCoord.xy), 0).rgb * u_exposure;
  vec3 mapped = clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
  o_color = vec4(srgb(mapped), 1.0);
}
