// SPDX-License-Identifier: MIT
#include "host_scene.h"

#include <GLES3/gl3.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>

#include <OpenImageIO/imageio.h>

#include "host_gltf.h"
#include "host_shaders.h"
#include "modrt/modrt.hpp"

namespace modrt::host {
namespace {

constexpr float kShadowNear = 0.01f, kShadowFar = 30.0f;
constexpr float kLightRadius = 0.05f;  // the 1/d^2 clamp and the marker's size (modrt-demo's default)
constexpr double kPi = 3.14159265358979323846;

struct Failure {
  std::string message;
};
[[noreturn]] void fail(const std::string& message) { throw Failure{message}; }
void check(const char* call, modrt_status s) {
  if (s != MODRT_OK) fail(std::string(call) + ": " + modrt_last_error());
}
void check_gl(const std::string& what) {
  const GLenum e = glGetError();
  if (e != GL_NO_ERROR) {
    char text[32];
    std::snprintf(text, sizeof text, "0x%04x", unsigned(e));
    fail("GL error " + std::string(text) + (e == GL_OUT_OF_MEMORY ? " (out of memory)" : "") + " in " + what);
  }
}

// The vertex of every draw (static meshes mapped onto the proxies; dynamic and clutter meshes
// as they are, a clutter mesh's lightmap = TEXCOORD_1 x res).
struct Vertex {
  glm::vec3 position{0.0f}, normal{0.0f, 1.0f, 0.0f};
  glm::vec4 tangent{1.0f, 0.0f, 0.0f, 1.0f};
  glm::vec2 uv{0.0f}, lightmap{0.0f};
  glm::vec3 face_u{1.0f, 0.0f, 0.0f}, face_v{0.0f, 1.0f, 0.0f};
};

enum Kind { kStatic = 0, kDynamic = 1, kClutter = 2, kMarker = 3 };
struct Draw {
  GLint first = 0;
  GLsizei count = 0;
  int material = 0;
  Kind kind = kStatic;
  int clutter = -1;
};

GLuint compile(GLenum type, std::initializer_list<const char*> parts, const char* name) {
  std::vector<const char*> sources(parts);
  const GLuint s = glCreateShader(type);
  glShaderSource(s, GLsizei(sources.size()), sources.data(), nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096] = {};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    fail(std::string("shader '") + name + "' does not compile: " + log);
  }
  return s;
}

GLuint program(const char* name, std::initializer_list<const char*> vs,
               std::initializer_list<const char*> fs) {
  const GLuint v = compile(GL_VERTEX_SHADER, vs, name), f = compile(GL_FRAGMENT_SHADER, fs, name);
  const GLuint p = glCreateProgram();
  glAttachShader(p, v);
  glAttachShader(p, f);
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096] = {};
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    fail(std::string("program '") + name + "' does not link: " + log);
  }
  return p;
}

void set_units(GLuint p, std::initializer_list<std::pair<const char*, int>> units) {
  glUseProgram(p);
  for (const auto& [name, unit] : units) glUniform1i(glGetUniformLocation(p, name), unit);
}

void bind(int unit, GLenum target, GLuint texture) {
  glActiveTexture(GLenum(GL_TEXTURE0 + unit));
  glBindTexture(target, texture);
}

GLuint float_texture(int width, int height, const float* rgba) {
  GLuint t = 0;
  glGenTextures(1, &t);
  glBindTexture(GL_TEXTURE_2D, t);
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, width, height);
  if (rgba) {
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width, height, GL_RGBA, GL_FLOAT, rgba);
  }
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  return t;
}

GLuint framebuffer(GLuint color, GLuint depth, const char* what) {
  GLuint f = 0;
  glGenFramebuffers(1, &f);
  glBindFramebuffer(GL_FRAMEBUFFER, f);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, color, 0);
  if (depth) glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth, 0);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    fail(std::string(what) +
         ": the framebuffer is not complete (float render targets need EXT_color_buffer_float)");
  return f;
}

// ---- the level, read through the C API ----

glm::dvec3 trilinear(const modrt_level_block& b, const glm::dvec3& p) {
  glm::dvec3 r(0.0);
  for (int c = 0; c < 8; ++c) {
    const double w = ((c & 1) ? p.x : 1 - p.x) * ((c & 2) ? p.y : 1 - p.y) * ((c & 4) ? p.z : 1 - p.z);
    r += w * glm::dvec3(b.corners[c][0], b.corners[c][1], b.corners[c][2]);
  }
  return r;
}

// A canonical point of block b in the world: turned by its quarter turns about +Y (each
// (x, y, z) -> (z, y, 1 - x)), then through the trilinear warp of its corners. (The corners are
// indexed in the turned cube's frame: modrt.h's "corner x + 2y + 4z of the canonical unit cube"
// holds for blocks without turns only.)
glm::dvec3 block_to_world(const modrt_level_block& b, glm::dvec3 p) {
  for (std::uint32_t t = 0; t < (b.quarter_turns & 3u); ++t) p = glm::dvec3(p.z, p.y, 1.0 - p.x);
  return trilinear(b, p);
}

// Where the dynamic object is in the probe volume, for the probe shader: its block, the lower
// corner of its 2 x 2 x 2 probes on the block's canonical g^3 grid and the trilinear weights
// (modrt_context_locate_probe: core's ProbeSampler, Newton on the block's warp).
struct ProbeCell {
  int block = 0;
  glm::ivec3 i0{0};
  glm::vec3 f{0.0f};
};
ProbeCell locate_probe_cell(const modrt_context* ctx, const glm::vec3& x) {
  modrt_probe_cell c = modrt::rt::sized<modrt_probe_cell>();
  const float position[3] = {x.x, x.y, x.z};
  check("modrt_context_locate_probe (the dynamic object)", modrt_context_locate_probe(ctx, position, &c));
  ProbeCell cell;
  cell.block = int(c.block);
  cell.i0 = glm::ivec3(c.lower[0], c.lower[1], c.lower[2]);
  cell.f = glm::vec3(c.weight[0], c.weight[1], c.weight[2]);
  return cell;
}

// The level's present faces as wall meshes (a scene whose extras.modrt_level.proxy_walls is
// true, the default, models no walls of its own): 4 x 4 quads per face through the block's
// warp, one material per albedo.
void add_proxy_walls(const std::vector<modrt_level_block>& blocks, HostScene& scene) {
  std::map<std::tuple<float, float, float>, std::size_t> mesh_of;
  constexpr int k = 4;
  for (const modrt_level_block& b : blocks) {
    const glm::dvec3 centre = block_to_world(b, glm::dvec3(0.5));
    for (int f = 0; f < 6; ++f) {
      if (!(b.face_mask & (1u << f))) continue;
      const glm::vec3 albedo(b.albedo[f][0], b.albedo[f][1], b.albedo[f][2]);
      const auto key = std::make_tuple(albedo.r, albedo.g, albedo.b);
      auto it = mesh_of.find(key);
      if (it == mesh_of.end()) {
        HostMaterial m;
        m.name = "wall " + std::to_string(mesh_of.size());
        m.base_color = albedo;
        scene.materials.push_back(m);
        HostMesh mesh;
        mesh.name = m.name;
        mesh.material = int(scene.materials.size()) - 1;
        scene.meshes.push_back(mesh);
        it = mesh_of.emplace(key, scene.meshes.size() - 1).first;
      }
      HostMesh& m = scene.meshes[it->second];
      const int axis = f / 2, ua = (axis + 1) % 3, va = (axis + 2) % 3;
      auto at = [&](double u, double v) {
        glm::dvec3 p(0.0);
        p[axis] = f % 2, p[ua] = u, p[va] = v;
        return block_to_world(b, p);
      };
      for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
          glm::dvec3 p[4] = {at(double(i) / k, double(j) / k), at(double(i + 1) / k, double(j) / k),
                             at(double(i + 1) / k, double(j + 1) / k), at(double(i) / k, double(j + 1) / k)};
          glm::dvec3 n = glm::normalize(glm::cross(p[2] - p[0], p[3] - p[1]));
          if (glm::dot(n, centre - p[0]) < 0.0) std::swap(p[1], p[3]), n = -n;  // face into the block
          const std::uint32_t base = std::uint32_t(m.position.size());
          for (const glm::dvec3& q : p) m.position.push_back(glm::vec3(q)), m.normal.push_back(glm::vec3(n));
          for (std::uint32_t q : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + q);
        }
    }
  }
}

// ---- the clutter lightmap's cells ----

double cross2(glm::dvec2 a, glm::dvec2 b) { return a.x * b.y - a.y * b.x; }

// Area of triangle t (UV) inside the square [x0, x1] x [y0, y1] (Sutherland-Hodgman).
double overlap_area(const std::array<glm::dvec2, 3>& t, double x0, double y0, double x1, double y1) {
  std::vector<glm::dvec2> poly(t.begin(), t.end()), next;
  auto clip = [&](auto inside, auto cut) {
    next.clear();
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const glm::dvec2 a = poly[i], b = poly[(i + 1) % poly.size()];
      const bool ia = inside(a), ib = inside(b);
      if (ia) next.push_back(a);
      if (ia != ib) next.push_back(cut(a, b));
    }
    poly.swap(next);
  };
  auto lerp_x = [](double x) {
    return [x](glm::dvec2 a, glm::dvec2 b) { return glm::mix(a, b, (x - a.x) / (b.x - a.x)); };
  };
  auto lerp_y = [](double y) {
    return [y](glm::dvec2 a, glm::dvec2 b) { return glm::mix(a, b, (y - a.y) / (b.y - a.y)); };
  };
  clip([&](glm::dvec2 p) { return p.x >= x0; }, lerp_x(x0));
  clip([&](glm::dvec2 p) { return p.x <= x1; }, lerp_x(x1));
  clip([&](glm::dvec2 p) { return p.y >= y0; }, lerp_y(y0));
  clip([&](glm::dvec2 p) { return p.y <= y1; }, lerp_y(y1));
  double a = 0.0;
  for (std::size_t i = 0; i < poly.size(); ++i) a += cross2(poly[i], poly[(i + 1) % poly.size()]);
  return 0.5 * std::abs(a);
}

glm::dvec3 barycentric(const std::array<glm::dvec2, 3>& t, glm::dvec2 p) {
  const double d = cross2(t[1] - t[0], t[2] - t[0]);
  const double b1 = cross2(p - t[0], t[2] - t[0]) / d, b2 = cross2(t[1] - t[0], p - t[0]) / d;
  return {1.0 - b1 - b2, b1, b2};
}

glm::dvec2 closest_in_triangle(const std::array<glm::dvec2, 3>& t, glm::dvec2 p) {
  const glm::dvec3 w = barycentric(t, p);
  if (w.x >= 0 && w.y >= 0 && w.z >= 0) return p;
  glm::dvec2 best = t[0];
  double best_d = 1e300;
  for (int e = 0; e < 3; ++e) {
    const glm::dvec2 a = t[std::size_t(e)], b = t[std::size_t((e + 1) % 3)];
    const double s = std::clamp(glm::dot(p - a, b - a) / std::max(glm::dot(b - a, b - a), 1e-300), 0.0, 1.0);
    const glm::dvec2 q = a + s * (b - a);
    if (glm::dot(q - p, q - p) < best_d) best_d = glm::dot(q - p, q - p), best = q;
  }
  return best;
}

// The runtime gives each clutter texel's world position and normal and where it lies in its
// clutter atlas, not the lightmap cell of the object's res x res grid it stands for, which is
// what the mesh's TEXCOORD_1 addresses. The cells are found again as the operator build made
// them (a lightmapper's usual rasterization, docs/drt.md): every cell the UV triangles overlap
// is a texel, in row-major cell order, at the point of its triangle closest to the cell centre.
// Each cell's point is checked against its texel's position, so a .modrtdrt built from another
// mesh or res is an error, not a wrong image. The one-cell padding ring copies its first used
// 4-, then diagonal neighbour. Returns per cell the index of the object's texel, or -1.
std::vector<std::int32_t> find_clutter_cells(const HostScene& scene, int object, std::size_t texel_begin,
                                             std::size_t texel_count,
                                             const std::vector<modrt_clutter_texel>& texels,
                                             double tolerance) {
  const HostClutter& c = scene.clutter[std::size_t(object)];
  const int res = c.res;
  const double cell = 1.0 / res;
  struct Tri {
    std::array<glm::dvec2, 3> uv;
    std::array<glm::dvec3, 3> p;
  };
  std::vector<Tri> tris;
  for (const HostMesh& m : scene.meshes) {
    if (m.clutter != object) continue;
    for (std::size_t i = 0; i + 2 < m.indices.size(); i += 3) {
      Tri t;
      for (int k = 0; k < 3; ++k) {
        t.uv[std::size_t(k)] = glm::dvec2(m.uv1[m.indices[i + std::size_t(k)]]);
        t.p[std::size_t(k)] = glm::dvec3(m.position[m.indices[i + std::size_t(k)]]);
      }
      if (std::abs(cross2(t.uv[1] - t.uv[0], t.uv[2] - t.uv[0])) > 1e-14) tris.push_back(t);
    }
  }
  const std::size_t cells = std::size_t(res) * std::size_t(res);
  std::vector<int> owner(cells, -1), fallback(cells, -1);
  std::vector<double> owner_depth(cells, -1.0), fallback_overlap(cells, 0.0);
  for (std::size_t ti = 0; ti < tris.size(); ++ti) {
    const Tri& t = tris[ti];
    double x_lo = 1, y_lo = 1, x_hi = 0, y_hi = 0;
    for (const glm::dvec2& uv : t.uv)
      x_lo = std::min(x_lo, uv.x), x_hi = std::max(x_hi, uv.x), y_lo = std::min(y_lo, uv.y),
      y_hi = std::max(y_hi, uv.y);
    const int i0 = std::clamp(int(std::floor(x_lo * res)), 0, res - 1),
              i1 = std::clamp(int(std::floor(x_hi * res)), 0, res - 1);
    const int j0 = std::clamp(int(std::floor(y_lo * res)), 0, res - 1),
              j1 = std::clamp(int(std::floor(y_hi * res)), 0, res - 1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const std::size_t ci = std::size_t(j) * std::size_t(res) + std::size_t(i);
        const double overlap = overlap_area(t.uv, i * cell, j * cell, (i + 1) * cell, (j + 1) * cell);
        if (overlap <= 0) continue;
        const glm::dvec3 w = barycentric(t.uv, {(i + 0.5) * cell, (j + 0.5) * cell});
        const double depth = std::min({w.x, w.y, w.z});
        if (depth >= -1e-9 && depth > owner_depth[ci]) owner[ci] = int(ti), owner_depth[ci] = depth;
        if (overlap > fallback_overlap[ci]) fallback[ci] = int(ti), fallback_overlap[ci] = overlap;
      }
  }
  std::vector<std::int32_t> cell_texel(cells, -1);
  std::size_t next = 0;
  double worst = 0.0;
  for (std::size_t ci = 0; ci < cells; ++ci) {
    const int t = owner[ci] >= 0 ? owner[ci] : fallback[ci];
    if (t < 0) continue;
    if (next < texel_count) {
      const Tri& tri = tris[std::size_t(t)];
      const glm::dvec2 centre{(double(ci % std::size_t(res)) + 0.5) * cell,
                              (double(ci / std::size_t(res)) + 0.5) * cell};
      const glm::dvec3 w = barycentric(tri.uv, closest_in_triangle(tri.uv, centre));
      const glm::dvec3 p = w.x * tri.p[0] + w.y * tri.p[1] + w.z * tri.p[2];
      const modrt_clutter_texel& x = texels[texel_begin + next];
      worst = std::max(worst, glm::length(p - glm::dvec3(x.position[0], x.position[1], x.position[2])));
    }
    cell_texel[ci] = std::int32_t(next++);
  }
  const std::string what = "clutter object " + std::to_string(object) + " ('" + c.name + "')";
  if (next != texel_count)
    fail(what + ": its TEXCOORD_1 at res " + std::to_string(res) + " covers " + std::to_string(next) +
         " lightmap cells, the clutter file has " + std::to_string(texel_count) +
         " texels for it: the .modrtdrt was built from another mesh or res (extras.modrt_clutter.res)");
  if (worst > tolerance)
    fail(what + ": a lightmap cell's surface point is " + std::to_string(worst) +
         " from its clutter texel's position: the .modrtdrt was built from another mesh");
  constexpr std::array<std::array<int, 2>, 8> kNeighbours{
      {{-1, 0}, {1, 0}, {0, -1}, {0, 1}, {-1, -1}, {1, -1}, {-1, 1}, {1, 1}}};
  std::vector<std::int32_t> padded = cell_texel;
  for (int j = 0; j < res; ++j)
    for (int i = 0; i < res; ++i) {
      const std::size_t ci = std::size_t(j) * std::size_t(res) + std::size_t(i);
      if (cell_texel[ci] >= 0) continue;
      for (const auto& [di, dj] : kNeighbours) {
        const int ni = i + di, nj = j + dj;
        if (ni < 0 || nj < 0 || ni >= res || nj >= res) continue;
        const std::int32_t n = cell_texel[std::size_t(nj) * std::size_t(res) + std::size_t(ni)];
        if (n >= 0) {
          padded[ci] = n;
          break;
        }
      }
    }
  return padded;
}

void write_png(const std::string& path, int width, int height, const std::vector<unsigned char>& rgba) {
  std::vector<unsigned char> rgb(std::size_t(width) * std::size_t(height) * 3);
  for (int y = 0; y < height; ++y)  // GL's first row is the bottom
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c)
        rgb[(std::size_t(height - 1 - y) * std::size_t(width) + std::size_t(x)) * 3 + std::size_t(c)] =
            rgba[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 4 + std::size_t(c)];
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(path);
  if (!out) fail("cannot write " + path + ": " + OIIO::geterror());
  const OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
  if (!out->open(path, spec) || !out->write_image(OIIO::TypeDesc::UINT8, rgb.data()) || !out->close())
    fail("cannot write " + path + ": " + out->geterror());
}

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// Every GL object of the renderer, deleted with the context still current.
struct Gl {
  std::vector<GLuint> programs, textures, framebuffers, buffers, vaos;
  ~Gl() {
    for (GLuint p : programs) glDeleteProgram(p);
    if (!framebuffers.empty()) glDeleteFramebuffers(GLsizei(framebuffers.size()), framebuffers.data());
    if (!textures.empty()) glDeleteTextures(GLsizei(textures.size()), textures.data());
    if (!buffers.empty()) glDeleteBuffers(GLsizei(buffers.size()), buffers.data());
    if (!vaos.empty()) glDeleteVertexArrays(GLsizei(vaos.size()), vaos.data());
  }
  GLuint texture(GLuint t) { return textures.push_back(t), t; }
  GLuint fbo(GLuint f) { return framebuffers.push_back(f), f; }
  GLuint prog(GLuint p) { return programs.push_back(p), p; }
};

void run(const SceneModeOptions& o) {
  // ---- the app's assets: its scene, then modrt's dictionary, level and clutter operators ----
  HostScene scene;
  std::string error;
  if (!load_host_scene(o.scene, scene, error)) fail(error);
  for (const std::string& w : scene.warnings)
    std::fprintf(stderr, "modrt-embed-host: warning: %s\n", w.c_str());
  modrt::rt::Dictionary dict;
  if (modrt::rt::Error e = modrt::rt::Dictionary::load_file(o.dictionary.c_str(), dict)) fail(e.message);
  modrt::rt::Level level;
  if (modrt::rt::Error e = modrt::rt::Level::load_file(o.level.c_str(), level)) fail(e.message);
  const modrt_level_info info = level.info();
  std::vector<modrt_level_block> blocks(info.block_count);
  for (std::uint32_t b = 0; b < info.block_count; ++b) {
    blocks[b].struct_size = sizeof(modrt_level_block);
    check("modrt_level_get_block", modrt_level_get_block(level.get(), b, &blocks[b]));
  }
  if (scene.proxy_walls) add_proxy_walls(blocks, scene);

  modrt_context_options options = modrt::rt::default_options(MODRT_BACKEND_GLES);
  options.bounces = context_bounces(o.bounces);
  options.vector_irradiance = 1;
  options.timing = 1;
  modrt::rt::Context ctx;
  modrt::rt::Error created = modrt::rt::Context::create(dict, level, options, ctx);
  if (created.code == MODRT_ERROR_UNSUPPORTED) {
    std::fprintf(stderr, "modrt-embed-host: warning: no vector irradiance (%s); normal maps read the atlas\n",
                 created.message.c_str());
    options.vector_irradiance = 0;
    created = modrt::rt::Context::create(dict, level, options, ctx);
  }
  if (created) fail(created.message);
  const modrt_sizes sizes = ctx.sizes();

  // Clutter: the operators from the file, checked against the level by set_clutter and against
  // the scene's clutter meshes here.
  modrt_clutter_info clutter_info = modrt::rt::sized<modrt_clutter_info>();
  std::vector<modrt_clutter_texel> texels;
  std::vector<std::size_t> object_begin, object_count;
  if (!o.clutter.empty()) {
    if (scene.clutter.empty())
      fail(o.clutter +
           ": the scene has no clutter objects (nodes marked extras.modrt_clutter) to light with it");
    modrt_clutter* clutter = nullptr;
    check("modrt_clutter_load_file", modrt_clutter_load_file(o.clutter.c_str(), nullptr, &clutter));
    const modrt_status set = modrt_context_set_clutter(ctx.get(), clutter);
    const std::string set_error = set == MODRT_OK ? std::string() : modrt_last_error();
    modrt_status got = modrt_clutter_get_info(clutter, &clutter_info);
    if (got == MODRT_OK) {
      texels.resize(clutter_info.texel_count);
      got = modrt_clutter_get_texels(clutter, texels.data(), texels.size());
    }
    const std::string got_error = got == MODRT_OK ? std::string() : modrt_last_error();
    modrt_clutter_destroy(clutter);  // the context keeps its reference
    if (set != MODRT_OK) fail("modrt_context_set_clutter: " + set_error);
    if (got != MODRT_OK) fail(o.clutter + ": " + got_error);
    if (clutter_info.object_count != scene.clutter.size())
      fail(o.clutter + ": " + std::to_string(clutter_info.object_count) + " clutter objects, the scene has " +
           std::to_string(scene.clutter.size()) + " (nodes marked extras.modrt_clutter)");
    object_begin.assign(scene.clutter.size(), 0);
    object_count.assign(scene.clutter.size(), 0);
    for (std::size_t t = 0; t < texels.size(); ++t) {
      const std::uint32_t k = texels[t].object;
      if (k >= scene.clutter.size())
        fail(o.clutter + ": texel " + std::to_string(t) + " names object " + std::to_string(k));
      if (object_count[k] == 0) object_begin[k] = t;
      ++object_count[k];
    }
  } else if (!scene.clutter.empty()) {
    fail(o.scene + ": the scene has " + std::to_string(scene.clutter.size()) +
         " clutter objects (extras.modrt_clutter); give their DRT operators with --clutter FILE.modrtdrt "
         "(modrt-demo --scene S --save-clutter FILE)");
  }

  // ---- geometry: static meshes mapped onto the proxies (lightmap UVs), the rest as it is ----
  std::vector<Vertex> vertices;
  std::vector<Draw> draws;
  std::size_t static_triangles = 0, mapped_triangles = 0, cut_triangles = 0;
  for (const HostMesh& m : scene.meshes) {
    if (m.dynamic || m.clutter >= 0 || m.indices.empty()) continue;
    modrt_mesh_input in;
    modrt_mesh_input_init(&in);
    in.positions = &m.position[0].x;
    in.normals = &m.normal[0].x;
    in.vertex_count = m.position.size();
    in.indices = m.indices.data();
    in.index_count = m.indices.size();
    std::size_t corners = 0, written = 0;
    check("modrt_level_map_mesh_bound", modrt_level_map_mesh_bound(level.get(), &in, &corners));
    std::vector<modrt_mapped_corner> out(corners);
    modrt_mesh_map_stats stats = modrt::rt::sized<modrt_mesh_map_stats>();
    check("modrt_level_map_mesh",
          modrt_level_map_mesh(level.get(), &in, out.data(), out.size(), &written, &stats));
    static_triangles += stats.triangles, mapped_triangles += written / 3,
        cut_triangles += stats.split_triangles;
    Draw d{GLint(vertices.size()), GLsizei(written), m.material, kStatic, -1};
    for (std::size_t k = 0; k < written; ++k) {
      const modrt_mapped_corner& c = out[k];
      Vertex v;
      v.position = glm::vec3(c.position[0], c.position[1], c.position[2]);
      v.normal = glm::vec3(c.normal[0], c.normal[1], c.normal[2]);
      v.lightmap = glm::vec2(c.lightmap[0], c.lightmap[1]);
      v.face_u = glm::vec3(c.face_u[0], c.face_u[1], c.face_u[2]);
      v.face_v = glm::vec3(c.face_v[0], c.face_v[1], c.face_v[2]);
      // The app's own attributes, interpolated onto cut corners with the barycentric weights.
      glm::vec2 uv(0.0f);
      glm::vec4 tangent(0.0f);
      for (int j = 0; j < 3; ++j) {
        const std::uint32_t vi = m.indices[3 * std::size_t(c.triangle) + std::size_t(j)];
        if (!m.uv.empty()) uv += c.barycentric[j] * m.uv[vi];
        if (!m.tangent.empty()) tangent += c.barycentric[j] * m.tangent[vi];
      }
      v.uv = uv;
      if (!m.tangent.empty()) v.tangent = glm::vec4(glm::vec3(tangent), tangent.w < 0.0f ? -1.0f : 1.0f);
      vertices.push_back(v);
    }
    draws.push_back(d);
  }
  auto add_plain = [&](const HostMesh& m, Kind kind, float lightmap_scale) {
    Draw d{GLint(vertices.size()), GLsizei(m.indices.size()), m.material, kind, m.clutter};
    for (std::uint32_t i : m.indices) {
      Vertex v;
      v.position = m.position[i];
      v.normal = m.normal[i];
      if (!m.uv.empty()) v.uv = m.uv[i];
      if (!m.tangent.empty()) v.tangent = m.tangent[i];
      if (!m.uv1.empty()) v.lightmap = m.uv1[i] * lightmap_scale;
      vertices.push_back(v);
    }
    draws.push_back(d);
  };
  bool have_dynamic = false;
  for (const HostMesh& m : scene.meshes)
    if (m.dynamic) add_plain(m, kDynamic, 0.0f), have_dynamic = true;
  for (const HostMesh& m : scene.meshes)  // clutter last: they rebind the atlas unit
    if (m.clutter >= 0) add_plain(m, kClutter, float(scene.clutter[std::size_t(m.clutter)].res));
  // The light's marker: a small emissive sphere (radius 1, scaled by the draw).
  Draw marker{GLint(vertices.size()), 0, 0, kMarker, -1};
  {
    const int rings = 8, segments = 16;
    auto at = [&](int r, int s) {
      const float th = 3.14159265f * float(r) / float(rings), ph = 6.2831853f * float(s) / float(segments);
      Vertex v;
      v.normal = glm::vec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
      v.position = v.normal;
      return v;
    };
    for (int r = 0; r < rings; ++r)
      for (int s = 0; s < segments; ++s)
        for (auto [dr, ds] : {std::pair{0, 0}, {1, 0}, {0, 1}, {0, 1}, {1, 0}, {1, 1}})
          vertices.push_back(at(r + dr, s + ds));
    marker.count = GLsizei(vertices.size()) - marker.first;
  }
  std::printf(
      "scene %s: %zu meshes, %zu materials, %zu images, %zu clutter objects%s; %zu static triangles -> %zu "
      "mapped (%zu cut)\n",
      o.scene.c_str(), scene.meshes.size(), scene.materials.size(), scene.images.size(), scene.clutter.size(),
      have_dynamic ? ", a dynamic object" : "", static_triangles, mapped_triangles, cut_triangles);
  std::printf(
      "modrt %s: %s; level %u blocks, %u samples, atlas %ux%u, probe grid %u, bounces per update: %s\n",
      modrt_version_string(), ctx.description(), info.block_count, info.sample_count, sizes.atlas_width,
      sizes.atlas_height, sizes.probe_grid, o.bounces < 0 ? "converged" : std::to_string(o.bounces).c_str());

  // ---- GL objects ----
  Gl gl;
  while (glGetError() != GL_NO_ERROR) {
  }
  int format = 0;
  {
    std::uint32_t atlas = 0;
    check("modrt_context_get_atlas_texture", modrt_context_get_atlas_texture(ctx.get(), &atlas, &format));
  }
  const char* bits = format == 2 ? "#define LIGHTMAP_BITS 1\n" : "#define LIGHTMAP_BITS 0\n";
  const GLuint shadow_program = gl.prog(program("shadow", {kHeader, kShadowVert}, {kHeader, kShadowFrag}));
  const GLuint scene_program =
      gl.prog(program("scene", {kHeader, kSceneVert}, {kHeader, bits, kLightmapFetch, kLight, kSceneFrag}));
  const GLuint tonemap_program =
      gl.prog(program("tonemap", {kHeader, kFullscreenVert}, {kHeader, kTonemapFrag}));
  const GLuint clutter_program =
      gl.prog(program("clutter light", {kHeader, kFullscreenVert}, {kHeader, kLight, kClutterLightFrag}));
  set_units(scene_program, {{"u_shadow", 0},
                            {"u_normal_map", 1},
                            {"u_atlas", 2},
                            {"u_vector0", 3},
                            {"u_vector1", 4},
                            {"u_vector2", 5},
                            {"u_vector3", 6},
                            {"u_base_map", 7},
                            {"u_probes", 8},
                            {"u_clutter_cells", 9},
                            {"u_clutter_atlas", 10}});
  set_units(tonemap_program, {{"u_linear", 0}});
  set_units(clutter_program,
            {{"u_shadow", 0}, {"u_texel_position", 1}, {"u_texel_normal", 2}, {"u_texel_albedo", 3}});
  glUseProgram(0);
  auto loc = [](GLuint p, const char* name) { return glGetUniformLocation(p, name); };

  GLuint vao = 0, empty_vao = 0, vbo = 0;
  glGenVertexArrays(1, &vao);
  glGenVertexArrays(1, &empty_vao);
  gl.vaos = {vao, empty_vao};
  glGenBuffers(1, &vbo);
  gl.buffers.push_back(vbo);
  glBindVertexArray(vao);
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(vertices.size() * sizeof(Vertex)), vertices.data(),
               GL_STATIC_DRAW);
  check_gl("the vertex buffer (" + std::to_string(vertices.size()) + " vertices)");
  const struct {
    GLuint location;
    GLint size;
    std::size_t offset;
  } attributes[] = {{0, 3, offsetof(Vertex, position)}, {1, 3, offsetof(Vertex, normal)},
                    {2, 4, offsetof(Vertex, tangent)},  {3, 2, offsetof(Vertex, uv)},
                    {4, 2, offsetof(Vertex, lightmap)}, {5, 3, offsetof(Vertex, face_u)},
                    {6, 3, offsetof(Vertex, face_v)}};
  for (const auto& a : attributes) {
    glEnableVertexAttribArray(a.location);
    glVertexAttribPointer(a.location, a.size, GL_FLOAT, GL_FALSE, sizeof(Vertex),
                          reinterpret_cast<const void*>(a.offset));
  }
  glBindVertexArray(0);

  std::vector<GLuint> image_texture;
  for (const HostImage& img : scene.images) {
    GLuint t = 0;
    glGenTextures(1, &t);
    gl.texture(t);
    int levels = 1;
    while ((std::max(img.width, img.height) >> levels) > 0) ++levels;
    glBindTexture(GL_TEXTURE_2D, t);
    glTexStorage2D(GL_TEXTURE_2D, levels, GL_RGBA8, img.width, img.height);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, img.width, img.height, GL_RGBA, GL_UNSIGNED_BYTE,
                    img.rgba.data());
    glGenerateMipmap(GL_TEXTURE_2D);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    image_texture.push_back(t);
  }
  check_gl("the material textures");

  // The light's cube shadow map (depth, hardware comparison): the app's, handed to the runtime.
  GLuint shadow_cube = 0;
  glGenTextures(1, &shadow_cube);
  gl.texture(shadow_cube);
  glBindTexture(GL_TEXTURE_CUBE_MAP, shadow_cube);
  glTexStorage2D(GL_TEXTURE_CUBE_MAP, 1, GL_DEPTH_COMPONENT24, o.shadow_size, o.shadow_size);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  std::array<GLuint, 6> shadow_fbo{};
  for (int f = 0; f < 6; ++f) {
    glGenFramebuffers(1, &shadow_fbo[std::size_t(f)]);
    gl.fbo(shadow_fbo[std::size_t(f)]);
    glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo[std::size_t(f)]);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GLenum(GL_TEXTURE_CUBE_MAP_POSITIVE_X + f),
                           shadow_cube, 0);
    const GLenum none = GL_NONE;
    glDrawBuffers(1, &none);
    glReadBuffer(GL_NONE);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      fail("the shadow cube map (DEPTH_COMPONENT24) is not renderable");
  }
  const GLuint color = gl.texture(float_texture(o.width, o.height, nullptr));
  GLuint depth = 0;
  glGenTextures(1, &depth);
  gl.texture(depth);
  glBindTexture(GL_TEXTURE_2D, depth);
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_DEPTH_COMPONENT24, o.width, o.height);
  const GLuint scene_fbo = gl.fbo(framebuffer(color, depth, "the camera image (RGBA32F + depth)"));
  GLuint display = 0;
  glGenTextures(1, &display);
  gl.texture(display);
  glBindTexture(GL_TEXTURE_2D, display);
  glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, o.width, o.height);
  const GLuint display_fbo = gl.fbo(framebuffer(display, 0, "the display image (RGBA8)"));
  check_gl("the render targets");

  // Clutter: its texels as images for the direct-light pass, its albedo for the feedback, and
  // per object the cell -> clutter atlas texel map the scene shader reads the lightmap through.
  const std::size_t texel_count = texels.size();
  const int clutter_w = int(std::min<std::size_t>(std::max<std::size_t>(texel_count, 1), 1024));
  const int clutter_h =
      int((std::max<std::size_t>(texel_count, 1) + std::size_t(clutter_w) - 1) / std::size_t(clutter_w));
  GLuint clutter_fbo = 0;
  std::vector<float> clutter_readback, clutter_ld, clutter_albedo;
  std::vector<GLuint> clutter_cells(scene.clutter.size(), 0);
  std::array<GLuint, 3> texel_images{};  // position, normal, albedo
  if (texel_count > 0) {
    std::vector<float> position(4 * std::size_t(clutter_w) * std::size_t(clutter_h), 0.0f),
        normal(position.size(), 0.0f), albedo(position.size(), 0.0f);
    clutter_albedo.resize(3 * texel_count);
    for (std::size_t t = 0; t < texel_count; ++t) {
      const glm::vec3 a = scene.clutter[texels[t].object].albedo;
      for (int c = 0; c < 3; ++c) {
        position[4 * t + std::size_t(c)] = texels[t].position[c];
        normal[4 * t + std::size_t(c)] = texels[t].normal[c];
        albedo[4 * t + std::size_t(c)] = a[c];
        clutter_albedo[3 * t + std::size_t(c)] = a[c];
      }
    }
    texel_images[0] = gl.texture(float_texture(clutter_w, clutter_h, position.data()));
    texel_images[1] = gl.texture(float_texture(clutter_w, clutter_h, normal.data()));
    texel_images[2] = gl.texture(float_texture(clutter_w, clutter_h, albedo.data()));
    clutter_fbo = gl.fbo(
        framebuffer(gl.texture(float_texture(clutter_w, clutter_h, nullptr)), 0, "the clutter light target"));
    clutter_readback.resize(4 * std::size_t(clutter_w) * std::size_t(clutter_h));
    clutter_ld.resize(3 * texel_count);
    check("modrt_context_set_clutter_albedo",
          modrt_context_set_clutter_albedo(ctx.get(), clutter_albedo.data(), clutter_albedo.size()));
    std::vector<std::uint32_t> xy(2 * texel_count);
    check("modrt_context_get_clutter_texel_coords",
          modrt_context_get_clutter_texel_coords(ctx.get(), xy.data(), xy.size()));
    // Positions are compared in world units: a thousandth of the level's smallest extent.
    const double tolerance =
        1e-3 * std::min({info.bounds_max[0] - info.bounds_min[0], info.bounds_max[1] - info.bounds_min[1],
                         info.bounds_max[2] - info.bounds_min[2]});
    for (std::size_t k = 0; k < scene.clutter.size(); ++k) {
      const std::vector<std::int32_t> cells =
          find_clutter_cells(scene, int(k), object_begin[k], object_count[k], texels, tolerance);
      const int res = scene.clutter[k].res;
      std::vector<std::int32_t> map(2 * cells.size(), -1);
      for (std::size_t c = 0; c < cells.size(); ++c)
        if (cells[c] >= 0) {
          const std::size_t t = object_begin[k] + std::size_t(cells[c]);
          map[2 * c] = std::int32_t(xy[2 * t]), map[2 * c + 1] = std::int32_t(xy[2 * t + 1]);
        }
      GLuint t = 0;
      glGenTextures(1, &t);
      gl.texture(t);
      glBindTexture(GL_TEXTURE_2D, t);
      glTexStorage2D(GL_TEXTURE_2D, 1, GL_RG32I, res, res);
      glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
      glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, res, res, GL_RG_INTEGER, GL_INT, map.data());
      // An integer texture is complete only with NEAREST filters.
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
      clutter_cells[k] = t;
    }
    check_gl("the clutter textures");
  }

  // Uniforms.
  const GLint shadow_vp = loc(shadow_program, "u_view_proj"), shadow_offset = loc(shadow_program, "u_offset");
  struct LightLoc {
    GLint position, rgb, radius, planes;
  };
  auto light_loc = [&](GLuint p) {
    return LightLoc{loc(p, "u_light_position"), loc(p, "u_light_rgb"), loc(p, "u_light_radius"),
                    loc(p, "u_shadow_planes")};
  };
  const LightLoc scene_light = light_loc(scene_program), clutter_light = light_loc(clutter_program);
  const GLint u_vp = loc(scene_program, "u_view_proj"), u_offset = loc(scene_program, "u_offset"),
              u_kind = loc(scene_program, "u_kind"), u_base = loc(scene_program, "u_base_color"),
              u_has_base = loc(scene_program, "u_has_base_map"),
              u_has_nm = loc(scene_program, "u_has_normal_map"),
              u_nm_scale = loc(scene_program, "u_normal_scale"),
              u_use_vector = loc(scene_program, "u_use_vector"),
              u_probe_grid = loc(scene_program, "u_probe_grid"),
              u_probe_cell = loc(scene_program, "u_probe_cell"), u_probe_f = loc(scene_program, "u_probe_f"),
              u_exposure = loc(tonemap_program, "u_exposure");

  // The animation: the light circles (radius 12 % of the level's smallest extent, 48 frames a
  // turn) and the dynamic object swings (10 %, 64 frames), both from where the file puts them at
  // frame 0.
  const float extent =
      std::min({info.bounds_max[0] - info.bounds_min[0], info.bounds_max[1] - info.bounds_min[1],
                info.bounds_max[2] - info.bounds_min[2]});
  const HostCamera& cam = scene.camera;
  float zfar = cam.zfar;
  if (zfar <= 0.0f) {
    glm::vec3 lo(info.bounds_min[0], info.bounds_min[1], info.bounds_min[2]),
        hi(info.bounds_max[0], info.bounds_max[1], info.bounds_max[2]);
    for (const HostMesh& m : scene.meshes)
      if (!m.dynamic)
        for (const glm::vec3& p : m.position) lo = glm::min(lo, p), hi = glm::max(hi, p);
    zfar = std::max(100.0f, 2.0f * glm::length(hi - lo));
  }
  const glm::mat4 view_proj = glm::perspective(cam.yfov, float(o.width) / float(o.height), cam.znear, zfar) *
                              glm::lookAt(cam.position, cam.position + cam.forward, cam.up);
  const glm::vec3 light_rgb = scene.light.color * scene.light.intensity;
  std::vector<unsigned char> rgba(4 * std::size_t(o.width) * std::size_t(o.height));
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec) fail(o.out_dir + ": cannot create the output directory: " + ec.message());
  double t_shadow = 0, t_ld = 0, t_update = 0, t_render = 0, t_write = 0;

  for (int frame = 0; frame < o.frames; ++frame) {
    const double a = 2.0 * kPi * double(frame) / 48.0, b = 2.0 * kPi * double(frame) / 64.0;
    const glm::vec3 light_position =
        scene.light.position + 0.12f * extent * glm::vec3(float(std::sin(a)), 0.0f, float(std::cos(a) - 1.0));
    const glm::vec3 dynamic_offset =
        scene.dynamic_origin + 0.1f * extent * glm::vec3(float(std::sin(b)), 0.0f, 0.0f);

    // 1. The shadow cube map from the light over every mesh.
    Clock::time_point t0 = Clock::now();
    static const glm::vec3 dirs[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    static const glm::vec3 ups[6] = {{0, -1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {0, -1, 0}, {0, -1, 0}};
    const glm::mat4 shadow_proj = glm::perspective(glm::radians(90.0f), 1.0f, kShadowNear, kShadowFar);
    glUseProgram(shadow_program);
    glBindVertexArray(vao);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.5f, 2.0f);
    glViewport(0, 0, o.shadow_size, o.shadow_size);
    for (int f = 0; f < 6; ++f) {
      glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo[std::size_t(f)]);
      glClearDepthf(1.0f);
      glClear(GL_DEPTH_BUFFER_BIT);
      const glm::mat4 vp = shadow_proj * glm::lookAt(light_position, light_position + dirs[f], ups[f]);
      glUniformMatrix4fv(shadow_vp, 1, GL_FALSE, glm::value_ptr(vp));
      for (const Draw& d : draws) {
        const glm::vec3 off = d.kind == kDynamic ? dynamic_offset : glm::vec3(0.0f);
        glUniform3f(shadow_offset, off.x, off.y, off.z);
        glDrawArrays(GL_TRIANGLES, d.first, d.count);
      }
    }
    glDisable(GL_POLYGON_OFFSET_FILL);
    glBindVertexArray(0);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    check_gl("the shadow pass");
    glFinish();
    t_shadow += ms_since(t0);

    // 2. ld: the runtime evaluates the light at its proxy samples on the GPU with the app's
    // shadow map; the clutter's own direct light comes from the app's pass over its texels.
    t0 = Clock::now();
    modrt_light light;
    modrt_light_init(&light);
    light.type = MODRT_LIGHT_POINT;
    for (int c = 0; c < 3; ++c) light.position[c] = light_position[c], light.color[c] = scene.light.color[c];
    light.intensity = scene.light.intensity;
    light.radius = kLightRadius;
    light.shadows = 1;
    modrt_shadow_cube shadow;
    modrt_shadow_cube_init(&shadow);
    shadow.texture = shadow_cube;
    shadow.near_plane = kShadowNear, shadow.far_plane = kShadowFar;
    check("modrt_context_set_light_gpu", modrt_context_set_light_gpu(ctx.get(), &light, &shadow));
    if (texel_count > 0) {
      glBindFramebuffer(GL_FRAMEBUFFER, clutter_fbo);
      glViewport(0, 0, clutter_w, clutter_h);
      glDisable(GL_DEPTH_TEST);
      glUseProgram(clutter_program);
      glUniform3fv(clutter_light.position, 1, glm::value_ptr(light_position));
      glUniform3fv(clutter_light.rgb, 1, glm::value_ptr(light_rgb));
      glUniform1f(clutter_light.radius, kLightRadius);
      glUniform2f(clutter_light.planes, kShadowNear, kShadowFar);
      bind(0, GL_TEXTURE_CUBE_MAP, shadow_cube);
      for (int i = 0; i < 3; ++i) bind(1 + i, GL_TEXTURE_2D, texel_images[std::size_t(i)]);
      glBindVertexArray(empty_vao);
      glDrawArrays(GL_TRIANGLES, 0, 3);
      glBindVertexArray(0);
      glReadPixels(0, 0, clutter_w, clutter_h, GL_RGBA, GL_FLOAT, clutter_readback.data());
      glBindFramebuffer(GL_FRAMEBUFFER, 0);
      check_gl("the clutter light pass");
      for (std::size_t t = 0; t < texel_count; ++t)
        for (std::size_t c = 0; c < 3; ++c) {
          const float v = clutter_readback[4 * t + c];
          clutter_ld[3 * t + c] = std::isfinite(v) && v > 0.0f ? v : 0.0f;
        }
      check("modrt_context_set_clutter_light",
            modrt_context_set_clutter_light(ctx.get(), clutter_ld.data(), nullptr, clutter_ld.size()));
    }
    glFinish();
    t_ld += ms_since(t0);

    // 3. The update: b, r, lightmap and bounces, atlas, probes, vector irradiance, clutter.
    t0 = Clock::now();
    check("modrt_context_update", modrt_context_update(ctx.get()));
    std::uint32_t atlas = 0, probes = 0, clutter_atlas = 0, vector[4] = {0, 0, 0, 0};
    int f_atlas = 0;
    check("modrt_context_get_atlas_texture", modrt_context_get_atlas_texture(ctx.get(), &atlas, &f_atlas));
    if (f_atlas != format)
      fail("modrt_context_get_atlas_texture: the atlas format changed after the first update");
    if (options.vector_irradiance)
      check("modrt_context_get_vector_textures",
            modrt_context_get_vector_textures(ctx.get(), vector, nullptr));
    ProbeCell cell;
    if (have_dynamic && sizes.probe_grid > 0) {
      check("modrt_context_get_probe_texture",
            modrt_context_get_probe_texture(ctx.get(), &probes, nullptr, nullptr, nullptr));
      cell = locate_probe_cell(ctx.get(), dynamic_offset);
    }
    if (texel_count > 0)
      check("modrt_context_get_clutter_texture",
            modrt_context_get_clutter_texture(ctx.get(), &clutter_atlas, nullptr, nullptr, nullptr));
    glFinish();
    t_update += ms_since(t0);

    // 4. The camera image: every mesh, then the light's marker; tone mapped into RGBA8.
    t0 = Clock::now();
    glBindFramebuffer(GL_FRAMEBUFFER, scene_fbo);
    glViewport(0, 0, o.width, o.height);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glEnable(GL_CULL_FACE);  // walls are one-sided: two blocks' coplanar faces face apart
    glCullFace(GL_BACK);
    glDisable(GL_BLEND);
    glClearColor(0.0f, 0.0f, 0.0f, 1.0f);
    glClearDepthf(1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glUseProgram(scene_program);
    glUniform3fv(scene_light.position, 1, glm::value_ptr(light_position));
    glUniform3fv(scene_light.rgb, 1, glm::value_ptr(light_rgb));
    glUniform1f(scene_light.radius, kLightRadius);
    glUniform2f(scene_light.planes, kShadowNear, kShadowFar);
    glUniformMatrix4fv(u_vp, 1, GL_FALSE, glm::value_ptr(view_proj));
    glUniform1i(u_probe_grid, probes ? int(sizes.probe_grid) : 0);
    glUniform4i(u_probe_cell, cell.block, cell.i0.x, cell.i0.y, cell.i0.z);
    glUniform3f(u_probe_f, cell.f.x, cell.f.y, cell.f.z);
    bind(0, GL_TEXTURE_CUBE_MAP, shadow_cube);
    bind(2, GL_TEXTURE_2D, atlas);
    for (int i = 0; i < 4; ++i) bind(3 + i, GL_TEXTURE_2D, vector[i] ? vector[i] : atlas);
    bind(8, GL_TEXTURE_2D, probes ? probes : atlas);
    bind(10, GL_TEXTURE_2D, clutter_atlas ? clutter_atlas : atlas);
    glBindVertexArray(vao);
    for (const Draw& d : draws) {
      const HostMaterial& mat = scene.materials[std::size_t(d.material)];
      const GLuint normal_map = mat.normal_image >= 0 ? image_texture[std::size_t(mat.normal_image)] : 0;
      const GLuint base_map =
          mat.base_color_image >= 0 ? image_texture[std::size_t(mat.base_color_image)] : 0;
      const glm::vec3 off = d.kind == kDynamic ? dynamic_offset : glm::vec3(0.0f);
      glUniform3f(u_offset, off.x, off.y, off.z);
      glUniform1i(u_kind, int(d.kind));
      glUniform3fv(u_base, 1, glm::value_ptr(mat.base_color));
      glUniform1i(u_has_nm, normal_map != 0);
      glUniform1f(u_nm_scale, mat.normal_scale);
      glUniform1i(u_use_vector, vector[0] != 0 && normal_map != 0 && d.kind == kStatic);
      glUniform1i(u_has_base, base_map != 0);
      bind(1, GL_TEXTURE_2D, normal_map);
      bind(7, GL_TEXTURE_2D, base_map);
      bind(9, GL_TEXTURE_2D, d.kind == kClutter ? clutter_cells[std::size_t(d.clutter)] : 0);
      glDrawArrays(GL_TRIANGLES, d.first, d.count);
    }
    glUniform1i(u_kind, int(kMarker));
    const glm::mat4 marker_vp = view_proj * glm::translate(glm::mat4(1.0f), light_position) *
                                glm::scale(glm::mat4(1.0f), glm::vec3(std::max(kLightRadius, 0.01f)));
    glUniformMatrix4fv(u_vp, 1, GL_FALSE, glm::value_ptr(marker_vp));
    glUniform3f(u_offset, 0.0f, 0.0f, 0.0f);
    glDrawArrays(GL_TRIANGLES, marker.first, marker.count);
    glBindVertexArray(0);
    glDisable(GL_CULL_FACE);
    glDisable(GL_DEPTH_TEST);
    check_gl("the scene pass");
    glBindFramebuffer(GL_FRAMEBUFFER, display_fbo);
    glUseProgram(tonemap_program);
    glUniform1f(u_exposure, o.exposure);
    bind(0, GL_TEXTURE_2D, color);
    glBindVertexArray(empty_vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, o.width, o.height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glUseProgram(0);
    check_gl("tone mapping");
    t_render += ms_since(t0);

    t0 = Clock::now();
    char name[32];
    std::snprintf(name, sizeof name, "frame_%04d.png", frame);
    write_png((std::filesystem::path(o.out_dir) / name).string(), o.width, o.height, rgba);
    t_write += ms_since(t0);
  }
  const double n = double(o.frames);
  std::printf(
      "per frame (ms, mean of %d): shadows %.2f, ld (set_light_gpu%s) %.2f, update + textures %.2f, render "
      "%.2f, write PNG %.2f\n",
      o.frames, t_shadow / n, texel_count ? " + clutter light" : "", t_ld / n, t_update / n, t_render / n,
      t_write / n);
  std::printf("wrote %d frames to %s (frame_0000.png ... frame_%04d.png, %dx%d)\n", o.frames,
              o.out_dir.c_str(), o.frames - 1, o.width, o.height);
}

}  // namespace

int run_scene_mode(const SceneModeOptions& options) {
  try {
    run(options);
    return 0;
  } catch (const Failure& f) {
    std::fprintf(stderr, "modrt-embed-host: %s\n", f.message.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "modrt-embed-host: %s\n", e.what());
  }
  return 1;
}

}  // namespace modrt::host
