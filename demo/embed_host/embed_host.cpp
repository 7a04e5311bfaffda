// SPDX-License-Identifier: MIT
// modrt-embed-host: the pattern an Android or iOS app follows to embed modrt (docs/embedding.md).
// The app owns its GL context: this program creates one with plain EGL calls (Mesa's
// surfaceless platform, else the default display with a pbuffer), makes it current, and hands
// it to modrt through the C API (C++ wrapper modrt.hpp). It loads a dictionary from a file and
// a built level from a memory buffer (as from an app bundle), lights the level with a point
// light and a sun, updates it on the GPU, and then renders a frame with its own shader: the
// lightmap atlas texture (modrt_context_get_atlas_texture) drawn into the app's framebuffer,
// which it reads back and writes as a PNG. Only libmodrt_runtime.so, libEGL and libGLESv2 are
// linked (OpenImageIO writes the image, tinygltf reads the scene mode's glTF file).
//
//   modrt-embed-host DICTIONARY.modrt LEVEL.modrtlevel OUT.png [--scale N] [--albedo A] [--bounces N]
//
// The scene mode (host_scene.h) renders a glTF scene with the app's own renderer instead, lit
// every frame through the C API:
//
//   modrt-embed-host --scene S.gltf --dictionary D.modrt --level L.modrtlevel [--clutter C.modrtdrt]
//                    --out DIR [--frames N] [--width W] [--height H] [--bounces N] [--exposure E]
// Exit status: 0 on success, 2 for a usage error (unknown flag, bad value: the message names
// it), 77 when no EGL display or ES 3 context can be created, else 1.
#define EGL_EGLEXT_PROTOTYPES
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>

#include <CLI/CLI.hpp>

#include "cli_checks.h"
#include "host_scene.h"
#include "modrt/modrt.hpp"

namespace {

int fail(const char* what, const std::string& message) {
  std::fprintf(stderr, "modrt-embed-host: %s: %s\n", what, message.c_str());
  return 1;
}

// The app's EGL context: surfaceless where Mesa offers it, else a 1x1 pbuffer.
struct EglContext {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  EGLSurface surface = EGL_NO_SURFACE;
  std::string platform;
  ~EglContext() {
    if (display == EGL_NO_DISPLAY) return;
    eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (context != EGL_NO_CONTEXT) eglDestroyContext(display, context);
    if (surface != EGL_NO_SURFACE) eglDestroySurface(display, surface);
    eglTerminate(display);
  }
};

bool create_egl(EglContext& egl, std::string& error) {
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  const bool surfaceless = client && std::strstr(client, "EGL_MESA_platform_surfaceless");
  if (surfaceless) {
    egl.display = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    egl.platform = "EGL surfaceless (Mesa)";
  }
  if (egl.display == EGL_NO_DISPLAY) {
    egl.display = eglGetDisplay(EGL_DEFAULT_DISPLAY);
    egl.platform = "EGL default display, pbuffer";
  }
  EGLint major = 0, minor = 0;
  if (egl.display == EGL_NO_DISPLAY || !eglInitialize(egl.display, &major, &minor)) {
    error = "no EGL display";
    return false;
  }
  const bool pbuffer = egl.platform.find("pbuffer") != std::string::npos;
  const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE,
                                   pbuffer ? EGL_PBUFFER_BIT : 0, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint count = 0;
  if (!eglBindAPI(EGL_OPENGL_ES_API) || !eglChooseConfig(egl.display, config_attribs, &config, 1, &count) ||
      count < 1) {
    error = "no OpenGL ES 3 EGL config";
    return false;
  }
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0, EGL_NONE};
  egl.context = eglCreateContext(egl.display, config, EGL_NO_CONTEXT, context_attribs);
  if (egl.context == EGL_NO_CONTEXT) {
    error = "eglCreateContext failed";
    return false;
  }
  if (pbuffer) {
    const EGLint surface_attribs[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
    egl.surface = eglCreatePbufferSurface(egl.display, config, surface_attribs);
  }
  if (!eglMakeCurrent(egl.display, egl.surface, egl.surface, egl.context)) {
    error = "eglMakeCurrent failed";
    return false;
  }
  return true;
}

GLuint compile(GLenum type, const char* source, std::string& log) {
  GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char text[2048];
    glGetShaderInfoLog(s, sizeof text, nullptr, text);
    log = text;
  }
  return s;
}

// The app's own pass: the atlas, fetched texel by texel (every target format modrt may choose,
// including the float-bits RGBA32UI fallback), tone-mapped into the app's RGBA8 framebuffer.
const char* kVertex = R"(#version 300 es
void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(2.0 * p - 1.0, 0.0, 1.0);
})";
const char* kFragment = R"(#version 300 es
precision highp float;
precision highp int;
uniform highp sampler2D u_atlas_float;
uniform highp usampler2D u_atlas_bits;
uniform int u_bits;
uniform float u_exposure;
out vec4 color;
void main() {
  ivec2 texel = ivec2(floor(gl_FragCoord.xy / float(SCALE)));
  vec3 e = u_bits == 1 ? uintBitsToFloat(texelFetch(u_atlas_bits, texel, 0).rgb)
                       : texelFetch(u_atlas_float, texel, 0).rgb;
  e *= u_exposure;
  color = vec4(pow(e / (1.0 + e), vec3(1.0 / 2.2)), 1.0);
})";

}  // namespace

int main(int argc, char** argv) {
  // Every argument is checked: an unknown flag, a missing value or a value out of range is a
  // usage error (exit 2) naming the flag, never silently ignored.
  CLI::App app{
      "modrt-embed-host: an app-owned EGL context handed to modrt's C API; renders the lightmap atlas, or "
      "with --scene a glTF scene lit through the C API"};
  std::string dictionary_path, level_path, out_path;
  int scale = 16;
  int bounces = -1;
  float albedo_value = 0.7f;  // used only with --albedo: else the level's own per-face albedo
  modrt::host::SceneModeOptions scene;
  app.add_option("dictionary", dictionary_path, "atlas mode: dictionary file (.modrt)");
  app.add_option("level", level_path, "atlas mode: built level file (.modrtlevel)");
  app.add_option("out", out_path, "atlas mode: output PNG");
  app.add_option("--scale", scale, "atlas mode: pixels per atlas texel")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_option("--bounces", bounces,
                 "multi-bounce: N >= 0 feedback steps per update; -1: the converged multi-bounce (the "
                 "runtime's default)")
      ->check(CLI::Range(-1, 64))
      ->capture_default_str();
  CLI::Option* albedo_option =
      app.add_option("--albedo", albedo_value,
                     "atlas mode: one albedo for every sample instead of the level's own (authored per face)")
          ->check(modrt::demo::FiniteRange(0.0, 1.0));
  CLI::Option* scene_option =
      app.add_option("--scene", scene.scene, "scene mode: glTF 2.0 scene (.gltf or .glb) to render");
  app.add_option("--dictionary", scene.dictionary, "scene mode: dictionary file (.modrt)")
      ->needs(scene_option);
  app.add_option("--level", scene.level,
                 "scene mode: the scene's built level (.modrtlevel, modrt-level --save)")
      ->needs(scene_option);
  app.add_option("--clutter", scene.clutter,
                 "scene mode: the scene's DRT clutter operators (.modrtdrt, modrt-demo --save-clutter)")
      ->needs(scene_option);
  app.add_option("--out", scene.out_dir, "scene mode: output directory for frame_NNNN.png")
      ->needs(scene_option);
  app.add_option("--frames", scene.frames, "scene mode: frames to render")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str()
      ->needs(scene_option);
  app.add_option("--width", scene.width, "scene mode: image width")
      ->check(CLI::Range(16, 8192))
      ->capture_default_str()
      ->needs(scene_option);
  app.add_option("--height", scene.height, "scene mode: image height")
      ->check(CLI::Range(16, 8192))
      ->capture_default_str()
      ->needs(scene_option);
  app.add_option("--exposure", scene.exposure, "scene mode: exposure before tone mapping")
      ->check(modrt::demo::FiniteRange(1e-6, 1e6))
      ->capture_default_str()
      ->needs(scene_option);
  const char* usage =
      "usage: modrt-embed-host DICTIONARY.modrt LEVEL.modrtlevel OUT.png [--scale N] [--albedo A] [--bounces "
      "N]\n"
      "       modrt-embed-host --scene S.gltf --dictionary D.modrt --level L.modrtlevel [--clutter "
      "C.modrtdrt] "
      "--out DIR [--frames N] [--width W] [--height H] [--bounces N] [--exposure E]\n";
  try {
    app.parse(argc, argv);
    const bool scene_mode = scene_option->count() > 0;
    if (scene_mode && (!dictionary_path.empty() || !level_path.empty() || !out_path.empty()))
      throw CLI::ValidationError(
          "the scene mode (--scene) takes no positional arguments; give --dictionary, "
          "--level and --out");
    if (scene_mode && (scene.dictionary.empty() || scene.level.empty() || scene.out_dir.empty()))
      throw CLI::ValidationError("--scene needs --dictionary, --level and --out");
    if (scene_mode && albedo_option->count() > 0)
      throw CLI::ValidationError(
          "--albedo is for the atlas mode; the scene mode lights the level's own albedo");
    if (!scene_mode && (dictionary_path.empty() || level_path.empty() || out_path.empty()))
      throw CLI::ValidationError("the atlas mode needs DICTIONARY.modrt LEVEL.modrtlevel OUT.png");
  } catch (const CLI::ParseError& e) {
    if (app.exit(e) == 0) return 0;  // --help
    std::fputs(usage, stderr);
    return 2;
  }
  scene.bounces = bounces;

  // 1. The app's GL context.
  EglContext egl;
  std::string error;
  if (!create_egl(egl, error)) {
    fail("EGL", error);
    return 77;  // no EGL here: ctest counts the run as skipped (SKIP_RETURN_CODE)
  }
  std::printf("app context: %s | %s | %s\n", egl.platform.c_str(), glGetString(GL_RENDERER),
              glGetString(GL_VERSION));
  if (!scene.scene.empty()) return modrt::host::run_scene_mode(scene);

  // 2. Assets: the dictionary from a file, the level from memory (an app's bundle asset).
  modrt::rt::Dictionary dict;
  if (modrt::rt::Error e = modrt::rt::Dictionary::load_file(dictionary_path.c_str(), dict))
    return fail("dictionary", e.message);
  std::ifstream in(level_path, std::ios::binary);
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) return fail("level", "cannot read " + level_path);
  modrt::rt::Level level;
  if (modrt::rt::Error e =
          modrt::rt::Level::load_memory(bytes.data(), bytes.size(), level_path.c_str(), level))
    return fail("level", e.message);
  const modrt_level_info info = level.info();

  // 3. A GLES context of modrt on the app's current context (entry points via eglGetProcAddress).
  modrt_context_options options = modrt::rt::default_options(MODRT_BACKEND_GLES);
  options.timing = 1;
  options.bounces = modrt::host::context_bounces(bounces);
  options.vector_irradiance = 1;  // for normal maps; a dictionary without the operators says so
  modrt::rt::Context ctx;
  modrt::rt::Error created = modrt::rt::Context::create(dict, level, options, ctx);
  if (created.code == MODRT_ERROR_UNSUPPORTED && options.vector_irradiance) {
    std::printf("no vector irradiance: %s\n", created.message.c_str());
    options.vector_irradiance = 0;
    created = modrt::rt::Context::create(dict, level, options, ctx);
  }
  if (created) return fail("context", created.message);
  const modrt_sizes sizes = ctx.sizes();
  std::printf("modrt %s: %s; level %u blocks, %u samples, atlas %ux%u\n", modrt_version_string(),
              ctx.description(), info.block_count, info.sample_count, sizes.atlas_width, sizes.atlas_height);

  // 4. Light: the level's authored albedo (or the one of --albedo, as an app overrides it from
  // its own materials), a point light in the level's middle and a sun.
  if (albedo_option->count() > 0) {
    const std::vector<float> albedo(sizes.ld, albedo_value);
    if (modrt::rt::Error e = ctx.set_albedo(albedo.data(), albedo.size())) return fail("albedo", e.message);
  }
  modrt_light lights[2];
  modrt_light_init(&lights[0]);
  modrt_light_init(&lights[1]);
  lights[0].type = MODRT_LIGHT_POINT;
  for (int a = 0; a < 3; ++a) lights[0].position[a] = 0.5f * (info.bounds_min[a] + info.bounds_max[a]);
  lights[0].position[1] = info.bounds_min[1] + 0.7f * (info.bounds_max[1] - info.bounds_min[1]);
  lights[0].color[0] = 1.0f, lights[0].color[1] = 0.85f, lights[0].color[2] = 0.6f;
  lights[0].intensity = 4.0f;
  lights[0].radius = 0.05f;
  lights[0].shadows = 1;
  lights[1].type = MODRT_LIGHT_DIRECTIONAL;
  lights[1].direction[0] = 0.4f, lights[1].direction[1] = -1.0f, lights[1].direction[2] = 0.3f;
  lights[1].color[0] = 0.6f, lights[1].color[1] = 0.7f, lights[1].color[2] = 1.0f;
  lights[1].intensity = 1.0f;
  lights[1].shadows = 1;
  if (modrt::rt::Error e = ctx.set_lights(lights, 2)) return fail("lights", e.message);
  if (modrt::rt::Error e = ctx.update()) return fail("update", e.message);
  const modrt_timings t = ctx.timings();
  std::printf(
      "frame: lights %.3f ms (CPU), update %.3f ms (b %.3f, r %.3f, atlas %.3f, probes %.3f ms GPU)\n",
      double(t.light_ns) * 1e-6, double(t.update_ns) * 1e-6, double(t.b_ns) * 1e-6, double(t.r_ns) * 1e-6,
      double(t.atlas_ns) * 1e-6, double(t.probes_ns) * 1e-6);
  std::printf("bounces per update: %s\n", bounces < 0 ? "converged" : std::to_string(bounces).c_str());
  float sh[27];
  if (sizes.probe_grid > 0 && !ctx.probe_sh(lights[0].position, sh))
    std::printf("probe E/pi at the point light (SH9 DC, RGB): %.4f %.4f %.4f\n", double(sh[0]), double(sh[1]),
                double(sh[2]));
  // The whole probe volume in the world frame, as an app uploads it for its dynamic objects.
  if (sizes.probes > 0) {
    std::vector<float> volume(sizes.probes);
    if (modrt::rt::Error e = ctx.read_probes(volume.data(), volume.size())) return fail("probes", e.message);
    double dc = 0.0;
    for (std::size_t p = 0; p < volume.size(); p += 27) dc += double(volume[p]);
    std::printf("probe volume: %zu probes, mean E/pi (SH9 DC, R) %.4f\n", volume.size() / 27,
                dc / double(volume.size() / 27));
  }
  if (options.vector_irradiance) {
    std::uint32_t vector[4] = {0, 0, 0, 0};
    if (modrt::rt::Error e = modrt::rt::check(modrt_context_get_vector_textures(ctx.get(), vector, nullptr)))
      return fail("vector irradiance", e.message);
    std::printf("vector irradiance: 4 OHLSH atlases, GL textures %u %u %u %u\n", vector[0], vector[1],
                vector[2], vector[3]);
  }

  // 5. The app renders with the atlas texture into its own framebuffer.
  int format = 0;
  const GLuint atlas = ctx.atlas_texture(&format);
  if (atlas == 0) return fail("atlas", "no texture");
  const int width = int(sizes.atlas_width) * scale, height = int(sizes.atlas_height) * scale;
  GLuint target = 0, framebuffer = 0, vao = 0;
  glGenTextures(1, &target);
  glBindTexture(GL_TEXTURE_2D, target);
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, width, height);
  glGenFramebuffers(1, &framebuffer);
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, target, 0);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    return fail("framebuffer", "incomplete");
  std::string log;
  const std::string fragment =
      std::string(kFragment).replace(std::string(kFragment).find("SCALE"), 5, std::to_string(scale));
  const GLuint vs = compile(GL_VERTEX_SHADER, kVertex, log),
               fs = compile(GL_FRAGMENT_SHADER, fragment.c_str(), log);
  if (!log.empty()) return fail("shader", log);
  const GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  GLint linked = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &linked);
  if (!linked) return fail("shader", "link failed");
  glUseProgram(program);
  const bool bits = format == 2;  // RGBA32UI holding float bits
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, bits ? 0 : atlas);
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, bits ? atlas : 0);
  glUniform1i(glGetUniformLocation(program, "u_atlas_float"), 0);
  glUniform1i(glGetUniformLocation(program, "u_atlas_bits"), 1);
  glUniform1i(glGetUniformLocation(program, "u_bits"), bits ? 1 : 0);
  glUniform1f(glGetUniformLocation(program, "u_exposure"), 2.0f);
  glGenVertexArrays(1, &vao);
  glBindVertexArray(vao);
  glViewport(0, 0, width, height);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  std::vector<unsigned char> rgba(std::size_t(width) * std::size_t(height) * 4);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  if (GLenum e = glGetError(); e != GL_NO_ERROR) return fail("GL", "error " + std::to_string(e));

  // 6. The image (rows flipped: GL's first row is the bottom).
  std::vector<unsigned char> rgb(std::size_t(width) * std::size_t(height) * 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c)
        rgb[(std::size_t(height - 1 - y) * std::size_t(width) + std::size_t(x)) * 3 + std::size_t(c)] =
            rgba[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 4 + std::size_t(c)];
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(out_path);
  if (!out) return fail("image", "cannot write " + out_path + ": " + OIIO::geterror());
  const OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
  if (!out->open(out_path, spec) || !out->write_image(OIIO::TypeDesc::UINT8, rgb.data()) || !out->close())
    return fail("image", out->geterror());
  std::printf("wrote %s (%dx%d, atlas x%d)\n", out_path.c_str(), width, height, scale);

  glDeleteVertexArrays(1, &vao);
  glDeleteProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  glDeleteFramebuffers(1, &framebuffer);
  glDeleteTextures(1, &target);
  ctx.reset();  // modrt's GL objects go while the app's context is still current
  return 0;
}
