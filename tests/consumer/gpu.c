// SPDX-License-Identifier: MIT
/* The GPU half of the out-of-tree consumer (scripts/test-install.sh), plain C against the
 * installed runtime: the app owns an EGL context (Mesa's surfaceless platform here), renders ld
 * itself in its own fragment shader (a point light at the level's samples, from
 * modrt_level_get_samples), hands the texture to a GLES context with multi-bounce
 * (modrt_context_set_ld_texture, options.bounces), then samples the runtime's outputs in its own
 * shaders: the padded atlas, the four vector-irradiance atlases (normal-mapped surfaces) and the
 * world-frame probe texture. The same frame on a CPU context, with the same ld computed on the
 * CPU, is the reference.
 *
 *   modrt_consumer_gpu dictionary.modrt level.modrtlevel [clutter.modrtdrt]
 *
 * Given operators built for the level's clutter (modrt-demo --save-clutter), the clutter object
 * is lit by the same point light at its texels (modrt_clutter_get_texels) and its lightmap
 * texture (modrt_context_get_clutter_texture) is sampled too, at each texel's coordinates.
 *
 * Exits 0 when the GPU frame matches the CPU frame (relative L2 below 1e-4 on the atlas, each
 * vector-irradiance coefficient, the probes and the clutter lightmap), 77 when no EGL surfaceless GLES 3
 * context can be made, 1 otherwise. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include <modrt/modrt.h>

#include "consumer_check.h"

enum { kBounces = 2 };
static const float kLightPosition[3] = {0.5f, 0.6f, 0.45f};
static const float kLightIntensity[3] = {4.0f, 3.5f, 3.0f}; /* W/sr per channel */

/* ---- the app's own EGL context ---- */
static int make_context(EGLDisplay* display_out) {
  PFNEGLGETPLATFORMDISPLAYEXTPROC get_display =
      (PFNEGLGETPLATFORMDISPLAYEXTPROC)eglGetProcAddress("eglGetPlatformDisplayEXT");
  if (!get_display) return 0;
  EGLDisplay display = get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
  if (display == EGL_NO_DISPLAY || !eglInitialize(display, NULL, NULL)) return 0;
  const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE, EGL_PBUFFER_BIT,
                                   EGL_NONE};
  EGLConfig config;
  EGLint configs = 0;
  if (!eglChooseConfig(display, config_attribs, &config, 1, &configs) || configs < 1) return 0;
  if (!eglBindAPI(EGL_OPENGL_ES_API)) return 0;
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0, EGL_NONE};
  EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attribs);
  if (context == EGL_NO_CONTEXT) return 0;
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) return 0;
  *display_out = display;
  return 1;
}

static GLuint compile(GLenum type, const char* source) {
  GLuint shader = glCreateShader(type);
  glShaderSource(shader, 1, &source, NULL);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(shader, sizeof log, NULL, log);
    fprintf(stderr, "shader: %s\n", log);
    return 0;
  }
  return shader;
}

static const char* kVertex =
    "#version 300 es\n"
    "void main() {\n"
    "  vec2 p = vec2(float((gl_VertexID & 1) * 4 - 1), float((gl_VertexID & 2) * 2 - 1));\n"
    "  gl_Position = vec4(p, 0.0, 1.0);\n"
    "}\n";

static GLuint program(const char* fragment) {
  GLuint vs = compile(GL_VERTEX_SHADER, kVertex), fs = compile(GL_FRAGMENT_SHADER, fragment);
  if (!vs || !fs) return 0;
  GLuint p = glCreateProgram();
  glAttachShader(p, vs);
  glAttachShader(p, fs);
  glLinkProgram(p);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  return ok ? p : 0;
}

/* An RGBA32F texture and a framebuffer rendering into it. */
static GLuint float_target(int width, int height, const float* data, GLuint* framebuffer) {
  GLuint texture = 0;
  glGenTextures(1, &texture);
  glBindTexture(GL_TEXTURE_2D, texture);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, width, height, 0, GL_RGBA, GL_FLOAT, data);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glBindTexture(GL_TEXTURE_2D, 0);
  if (framebuffer) {
    glGenFramebuffers(1, framebuffer);
    glBindFramebuffer(GL_FRAMEBUFFER, *framebuffer);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture, 0);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) return 0;
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
  }
  return texture;
}

/* ld = albedo x E / pi of a point light, no shadows: the app's own direct light. The same
 * formula on the CPU (point_light_ld) and in the shader. */
static const char* kLdFragment =
    "#version 300 es\n"
    "precision highp float;\n"
    "uniform highp sampler2D u_position, u_normal, u_albedo;\n"
    "uniform vec3 u_light, u_intensity;\n"
    "out vec4 o;\n"
    "void main() {\n"
    "  ivec2 t = ivec2(gl_FragCoord.xy);\n"
    "  vec3 x = texelFetch(u_position, t, 0).xyz, n = texelFetch(u_normal, t, 0).xyz;\n"
    "  vec3 d = u_light - x;\n"
    "  float r2 = max(dot(d, d), 1e-8);\n"
    "  float cosine = max(dot(n, d) * inversesqrt(r2), 0.0);\n"
    "  o = vec4(texelFetch(u_albedo, t, 0).rgb * u_intensity * cosine / r2 / 3.14159265358979, 1.0);\n"
    "}\n";

static void point_light_at(const float* x, const float* n, const float* albedo, float* ld) {
  float d[3] = {kLightPosition[0] - x[0], kLightPosition[1] - x[1], kLightPosition[2] - x[2]};
  float r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  if (r2 < 1e-8f) r2 = 1e-8f;
  float cosine = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / sqrtf(r2);
  if (cosine < 0.0f) cosine = 0.0f;
  for (int c = 0; c < 3; ++c) ld[c] = albedo[c] * kLightIntensity[c] * cosine / r2 / 3.14159265358979f;
}

static void point_light_ld(const modrt_level_sample* samples, const float* albedo, size_t count, float* ld) {
  for (size_t s = 0; s < count; ++s) {
    const float* x = samples[s].position;
    const float* n = samples[s].normal;
    float d[3] = {kLightPosition[0] - x[0], kLightPosition[1] - x[1], kLightPosition[2] - x[2]};
    float r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if (r2 < 1e-8f) r2 = 1e-8f;
    float cosine = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / sqrtf(r2);
    if (cosine < 0.0f) cosine = 0.0f;
    for (int c = 0; c < 3; ++c)
      ld[3 * s + (size_t)c] =
          albedo[3 * s + (size_t)c] * kLightIntensity[c] * cosine / r2 / 3.14159265358979f;
  }
}

/* Copies `texels` texels of a runtime texture (float formats: RGBA32F / RGBA16F; bits32: RGBA32UI
 * holding float bits) into a width-wide RGBA32F target with the app's own shader, and reads
 * that back: what a renderer samples. out: 3 floats per texel. */
static int sample_runtime_texture(GLuint texture, int format, int width, size_t texels, float* out) {
  static const char* kFloat =
      "#version 300 es\n"
      "precision highp float;\n"
      "uniform highp sampler2D u_tex;\n"
      "out vec4 o;\n"
      "void main() { o = texelFetch(u_tex, ivec2(gl_FragCoord.xy), 0); }\n";
  static const char* kBits =
      "#version 300 es\n"
      "precision highp float;\n"
      "uniform highp usampler2D u_tex;\n"
      "out vec4 o;\n"
      "void main() { o = uintBitsToFloat(texelFetch(u_tex, ivec2(gl_FragCoord.xy), 0)); }\n";
  const int rows = (int)((texels + (size_t)width - 1) / (size_t)width);
  GLuint fb = 0, target = float_target(width, rows, NULL, &fb), p = program(format == 2 ? kBits : kFloat);
  if (!target || !p) return 0;
  glBindFramebuffer(GL_FRAMEBUFFER, fb);
  glViewport(0, 0, width, rows);
  glUseProgram(p);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, texture);
  glUniform1i(glGetUniformLocation(p, "u_tex"), 0);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  float* rgba = malloc(sizeof(float) * 4 * (size_t)width * (size_t)rows);
  glReadPixels(0, 0, width, rows, GL_RGBA, GL_FLOAT, rgba);
  for (size_t i = 0; i < texels; ++i)
    for (int c = 0; c < 3; ++c) out[3 * i + (size_t)c] = rgba[4 * i + (size_t)c];
  free(rgba);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glDeleteFramebuffers(1, &fb);
  glDeleteTextures(1, &target);
  glDeleteProgram(p);
  return glGetError() == GL_NO_ERROR;
}

static double rel_l2(const float* a, const float* b, size_t n) {
  double num = 0.0, den = 0.0;
  for (size_t i = 0; i < n; ++i) {
    num += ((double)a[i] - b[i]) * ((double)a[i] - b[i]);
    den += (double)b[i] * b[i];
  }
  return den > 0.0 ? sqrt(num / den) : sqrt(num);
}

/* The clutter of argv[3] on a context: lit by the point light at its texels (albedo 0.5, which
 * also feeds its light back with the bounces). Returns the texel count, 0 on failure. */
static uint32_t attach_clutter(modrt_context* context, modrt_clutter* clutter) {
  modrt_clutter_info ci;
  memset(&ci, 0, sizeof ci);
  ci.struct_size = sizeof ci;
  if (modrt_clutter_get_info(clutter, &ci) != MODRT_OK || !ci.has_texel_geometry || ci.texel_count == 0) {
    fprintf(stderr, "clutter: no texels with positions (rebuild it with modrt-demo --save-clutter)\n");
    return 0;
  }
  const size_t n = ci.texel_count;
  modrt_clutter_texel* texels = malloc(n * sizeof *texels);
  float* clutter_ld = malloc(3 * n * sizeof *clutter_ld);
  float* albedo = malloc(3 * n * sizeof *albedo);
  if (!texels || !clutter_ld || !albedo) return 0;
  for (size_t i = 0; i < 3 * n; ++i) albedo[i] = 0.5f;
  int ok = modrt_clutter_get_texels(clutter, texels, n) == MODRT_OK;
  for (size_t t = 0; ok && t < n; ++t)
    point_light_at(texels[t].position, texels[t].normal, albedo, &clutter_ld[3 * t]);
  ok = ok && modrt_context_set_clutter(context, clutter) == MODRT_OK &&
       modrt_context_set_clutter_light(context, clutter_ld, NULL, 3 * n) == MODRT_OK &&
       modrt_context_set_clutter_albedo(context, albedo, 3 * n) == MODRT_OK;
  if (!ok) fprintf(stderr, "clutter: %s\n", modrt_last_error());
  free(texels), free(clutter_ld), free(albedo);
  return ok ? ci.texel_count : 0;
}

int main(int argc, char** argv) {
  if (argc != 3 && argc != 4) {
    fprintf(stderr, "usage: %s dictionary.modrt level.modrtlevel [clutter.modrtdrt]\n", argv[0]);
    return 2;
  }
  EGLDisplay display = EGL_NO_DISPLAY;
  if (!make_context(&display)) {
    fprintf(stderr, "modrt_consumer_gpu: no EGL surfaceless GLES 3 context: skipped\n");
    return 77;
  }
  modrt_dictionary* dict = NULL;
  modrt_level* level = NULL;
  CHECK(modrt_dictionary_load_file(argv[1], NULL, &dict));
  CHECK(modrt_level_load_file(argv[2], NULL, &level));
  modrt_clutter* clutter = NULL;
  if (argc == 4) CHECK(modrt_clutter_load_file(argv[3], NULL, &clutter));
  modrt_level_info info;
  memset(&info, 0, sizeof info);
  info.struct_size = sizeof info;
  CHECK(modrt_level_get_info(level, &info));
  const size_t samples = info.sample_count;

  /* Sample geometry and albedo, for the app's own direct light. */
  modrt_level_sample* geometry = malloc(sizeof(modrt_level_sample) * samples);
  float* albedo = malloc(sizeof(float) * 3 * samples);
  float* ld = malloc(sizeof(float) * 3 * samples);
  CHECK(modrt_level_get_samples(level, geometry, samples));
  CHECK(modrt_level_get_albedo(level, albedo, 3 * samples));
  point_light_ld(geometry, albedo, samples, ld);

  /* The GLES context on the app's GL context, and its ld layout. */
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = MODRT_BACKEND_GLES;
  o.bounces = kBounces;
  o.vector_irradiance = 1;
  modrt_context* gpu = NULL;
  CHECK(modrt_context_create(dict, level, &o, NULL, &gpu));
  uint32_t width = 0, height = 0;
  CHECK(modrt_context_get_ld_layout(gpu, &width, &height));
  if ((size_t)width * height < samples) {
    fprintf(stderr, "ld layout %ux%u holds fewer than %zu samples\n", width, height, samples);
    return 1;
  }

  /* The app's ld pass: positions, normals and albedo as textures in that layout, ld rendered. */
  const size_t texels = (size_t)width * height;
  float* position = calloc(4 * texels, sizeof(float));
  float* normal = calloc(4 * texels, sizeof(float));
  float* rho = calloc(4 * texels, sizeof(float));
  for (size_t s = 0; s < samples; ++s)
    for (int c = 0; c < 3; ++c) {
      position[4 * s + (size_t)c] = geometry[s].position[c];
      normal[4 * s + (size_t)c] = geometry[s].normal[c];
      rho[4 * s + (size_t)c] = albedo[3 * s + (size_t)c];
    }
  GLuint ld_fb = 0;
  GLuint ld_texture = float_target((int)width, (int)height, NULL, &ld_fb);
  GLuint position_tex = float_target((int)width, (int)height, position, NULL);
  GLuint normal_tex = float_target((int)width, (int)height, normal, NULL);
  GLuint albedo_tex = float_target((int)width, (int)height, rho, NULL);
  GLuint ld_program = program(kLdFragment);
  if (!ld_texture || !ld_program) {
    fprintf(stderr, "the ld pass could not be built (EXT_color_buffer_float?)\n");
    return 1;
  }
  glBindFramebuffer(GL_FRAMEBUFFER, ld_fb);
  glViewport(0, 0, (GLsizei)width, (GLsizei)height);
  glUseProgram(ld_program);
  const GLuint inputs[3] = {position_tex, normal_tex, albedo_tex};
  const char* names[3] = {"u_position", "u_normal", "u_albedo"};
  for (int i = 0; i < 3; ++i) {
    glActiveTexture(GL_TEXTURE0 + (GLenum)i);
    glBindTexture(GL_TEXTURE_2D, inputs[i]);
    glUniform1i(glGetUniformLocation(ld_program, names[i]), i);
  }
  glUniform3fv(glGetUniformLocation(ld_program, "u_light"), 1, kLightPosition);
  glUniform3fv(glGetUniformLocation(ld_program, "u_intensity"), 1, kLightIntensity);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glUseProgram(0);
  glActiveTexture(GL_TEXTURE0);
  if (glGetError() != GL_NO_ERROR) {
    fprintf(stderr, "the ld pass failed\n");
    return 1;
  }

  /* The frame: ld from the texture, kBounces feedback steps; nothing read back by the runtime. */
  const uint32_t clutter_texels = clutter ? attach_clutter(gpu, clutter) : 0;
  if (clutter && !clutter_texels) return 1;
  CHECK(modrt_context_set_ld_texture(gpu, ld_texture));
  CHECK(modrt_context_update(gpu));
  modrt_sizes sizes;
  memset(&sizes, 0, sizeof sizes);
  sizes.struct_size = sizeof sizes;
  CHECK(modrt_context_get_sizes(gpu, &sizes));
  uint32_t atlas_texture = 0, probe_texture = 0, probe_width = 0, probe_height = 0;
  int atlas_format = -1, probe_format = -1;
  CHECK(modrt_context_get_atlas_texture(gpu, &atlas_texture, &atlas_format));
  CHECK(modrt_context_get_probe_texture(gpu, &probe_texture, &probe_format, &probe_width, &probe_height));
  uint32_t vector_textures[4] = {0, 0, 0, 0};
  int vector_format = -1;
  CHECK(modrt_context_get_vector_textures(gpu, vector_textures, &vector_format));

  /* The reference: a CPU context, the same ld from memory, the same bounces. */
  o.backend = MODRT_BACKEND_CPU;
  modrt_context* cpu = NULL;
  CHECK(modrt_context_create(dict, level, &o, NULL, &cpu));
  if (clutter && !attach_clutter(cpu, clutter)) return 1;
  CHECK(modrt_context_set_ld(cpu, ld, 3 * samples));
  CHECK(modrt_context_update(cpu));
  float* atlas_cpu = malloc(sizeof(float) * sizes.atlas);
  float* probes_cpu = malloc(sizeof(float) * sizes.probes);
  CHECK(modrt_context_read_atlas(cpu, atlas_cpu, sizes.atlas));
  CHECK(modrt_context_read_probes(cpu, MODRT_PROBE_RADIANCE, probes_cpu, sizes.probes));

  /* What the app's shaders see. */
  float* atlas_gpu = malloc(sizeof(float) * sizes.atlas);
  float* probes_gpu = malloc(sizeof(float) * sizes.probes);
  if (!sample_runtime_texture(atlas_texture, atlas_format, (int)info.atlas_width, sizes.atlas / 3,
                              atlas_gpu) ||
      !sample_runtime_texture(probe_texture, probe_format, (int)probe_width, sizes.probes / 3, probes_gpu)) {
    fprintf(stderr, "sampling the runtime's textures failed\n");
    return 1;
  }
  const double atlas_error = rel_l2(atlas_gpu, atlas_cpu, sizes.atlas);
  const double probe_error = rel_l2(probes_gpu, probes_cpu, sizes.probes);
  /* The vector-irradiance coefficient atlases, in the atlas's layout and format: coefficient i
   * of E(n) / pi for a normal n in the texel's face frame (modrt.h). */
  float* vector_gpu = malloc(sizeof(float) * sizes.atlas);
  float* vector_cpu = malloc(sizeof(float) * sizes.atlas);
  double vector_error = 0.0;
  for (int i = 0; i < 4; ++i) {
    CHECK(modrt_context_read_vector_atlas(cpu, i, vector_cpu, sizes.atlas));
    if (!sample_runtime_texture(vector_textures[i], vector_format, (int)info.atlas_width, sizes.atlas / 3,
                                vector_gpu)) {
      fprintf(stderr, "sampling vector-irradiance texture %d failed\n", i);
      return 1;
    }
    const double e = rel_l2(vector_gpu, vector_cpu, sizes.atlas);
    if (!isnan(vector_error) && !(e <= vector_error)) vector_error = e; /* the worst; a NaN sticks */
  }
  /* The clutter lightmap texture, fetched whole by the app's shader and read at each texel's
   * coordinates, against the CPU context's clutter lightmap. */
  double clutter_error = 0.0;
  if (clutter) {
    uint32_t clutter_texture = 0, clutter_width = 0, clutter_height = 0;
    int clutter_format = -1;
    CHECK(modrt_context_get_clutter_texture(gpu, &clutter_texture, &clutter_format, &clutter_width,
                                            &clutter_height));
    const size_t n = clutter_texels, whole = (size_t)clutter_width * clutter_height;
    uint32_t* xy = malloc(2 * n * sizeof *xy);
    float* sampled = malloc(3 * whole * sizeof *sampled);
    float* at_texels = malloc(3 * n * sizeof *at_texels);
    float* clutter_cpu = malloc(3 * n * sizeof *clutter_cpu);
    if (!xy || !sampled || !at_texels || !clutter_cpu) return 1;
    CHECK(modrt_context_get_clutter_texel_coords(gpu, xy, 2 * n));
    CHECK(modrt_context_read_clutter_lightmap(cpu, clutter_cpu, 3 * n));
    if (!sample_runtime_texture(clutter_texture, clutter_format, (int)clutter_width, whole, sampled)) {
      fprintf(stderr, "sampling the clutter texture failed\n");
      return 1;
    }
    for (size_t t = 0; t < n; ++t) {
      if (xy[2 * t] >= clutter_width || xy[2 * t + 1] >= clutter_height) {
        fprintf(stderr, "clutter texel %zu at (%u, %u) is outside the %ux%u texture\n", t, xy[2 * t],
                xy[2 * t + 1], clutter_width, clutter_height);
        return 1;
      }
      const size_t at = (size_t)xy[2 * t + 1] * clutter_width + xy[2 * t];
      for (int c = 0; c < 3; ++c) at_texels[3 * t + (size_t)c] = sampled[3 * at + (size_t)c];
    }
    clutter_error = rel_l2(at_texels, clutter_cpu, 3 * n);
    double mean = 0.0;
    for (size_t i = 0; i < 3 * n; ++i) mean += clutter_cpu[i];
    printf(
        "modrt_consumer_gpu: clutter, %zu texels in a %ux%u texture: rel L2 %.2e against the CPU context "
        "(mean %.4g)\n",
        n, clutter_width, clutter_height, clutter_error, mean / (double)(3 * n));
    if (!(mean > 0.0)) clutter_error = INFINITY; /* a black clutter lightmap proves nothing */
    free(xy), free(sampled), free(at_texels), free(clutter_cpu);
  }
  double atlas_mean = 0.0;
  for (size_t i = 0; i < sizes.atlas; ++i) atlas_mean += atlas_cpu[i];
  atlas_mean /= (double)(sizes.atlas ? sizes.atlas : 1);
  printf(
      "modrt_consumer_gpu: %s, ld from the app's pass (%ux%u), %d bounces: atlas rel L2 %.2e against "
      "the CPU context (mean %.4g), vector irradiance worst coefficient rel L2 %.2e, world probes rel L2 "
      "%.2e (%ux%u texture)\n",
      modrt_context_description(gpu), width, height, kBounces, atlas_error, atlas_mean, vector_error,
      probe_error, probe_width, probe_height);
  const int ok = atlas_mean > 0.0 && atlas_error < 1e-4 && vector_error < 1e-4 && probe_error < 1e-4 &&
                 clutter_error < 1e-4;
  if (!ok) fprintf(stderr, "modrt_consumer_gpu: the GPU frame does not match the CPU frame\n");

  modrt_context_destroy(cpu);
  modrt_context_destroy(gpu);
  modrt_clutter_destroy(clutter);
  modrt_level_destroy(level);
  modrt_dictionary_destroy(dict);
  free(geometry), free(albedo), free(ld), free(position), free(normal), free(rho);
  free(atlas_cpu), free(probes_cpu), free(atlas_gpu), free(probes_gpu), free(vector_gpu), free(vector_cpu);
  eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  eglTerminate(display);
  return ok ? 0 : 1;
}
