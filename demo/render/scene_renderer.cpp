// SPDX-License-Identifier: MIT
#include "scene_renderer.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "modrt/checked_arithmetic.h"
#include "modrt/clutter_mesh.h"
#include "modrt/gles/gles_direct_light.h"
#include "modrt/level_geometry.h"
#include "modrt/light_policy.h"
#include "modrt/platform/gl_program.h"
#include "modrt/reference_runtime.h"

namespace modrt::demo {

// Shader sources, generated from demo/render/shaders/*.glsl by cmake/EmbedShaders.cmake.
extern const char* const kFullscreenVert;
extern const char* const kShadowVert;
extern const char* const kShadowFrag;
extern const char* const kSceneVert;
extern const char* const kSceneFrag;
extern const char* const kTonemapFrag;
extern const char* const kClutterGatherFrag;

namespace {

constexpr float kShadowNear = 0.01f, kShadowFar = 30.0f;
const char* const kHeader =
    "#version 300 es\nprecision highp float;\nprecision highp int;\nprecision highp sampler2D;\n"
    "precision highp samplerCubeShadow;\n";
// The probe texture's width when the renderer uploads it (a CPU backend's probes): rows of at
// most this many texels, within ES 3.0's minimum GL_MAX_TEXTURE_SIZE.
constexpr std::size_t kProbeTextureWidth = 2048;

struct DrawRange {
  GLint first = 0;
  GLsizei count = 0;
  int material = 0;
  bool dynamic = false;
  int clutter = -1;  // DemoScene::clutter object whose lightmap lights it
  // Drawn without culling (a double-sided dynamic or clutter mesh; a double-sided static mesh is
  // two culled draws instead, its back side mapped on its own).
  bool both_sides = false;
  bool casts_shadow = true;  // false for the back side of a static mesh: its front casts the same
};

// The camera image's light model: gles::light_glsl() once per light slot, its uniforms and
// functions renamed with the slot's suffix by the preprocessor (u_light_position ->
// u_light_position_1, direct_e_over_pi -> direct_e_over_pi_1, ...), and direct_e_over_pi_all
// summing the slots in use in light order, as add_ld sums the ld. Every global name of
// light.glsl must be listed here: one left out is declared twice with two lights, which the
// shader compiler refuses (DemoRender's two-light tests).
constexpr const char* kLightGlslNames[] = {"u_light_position", "u_light_rgb",        "u_light_radius",
                                           "u_spot_direction", "u_spot_cos",         "u_shadow",
                                           "u_shadow_params",  "u_falloff_floor_d2", "shadow_depth",
                                           "direct_e_over_pi", "u_shadow_matrix",    "directional_visible"};

std::string light_slot_name(const char* name, std::size_t slot) {
  return name + ("_" + std::to_string(slot));
}

std::string light_slots_glsl(std::size_t slots) {
  std::string out;
  for (std::size_t i = 0; i < slots; ++i) {
    for (const char* name : kLightGlslNames)
      out += std::string("#define ") + name + " " + light_slot_name(name, i) + "\n";
    out += gles::light_glsl();
    out += "\n";
    for (const char* name : kLightGlslNames) out += std::string("#undef ") + name + "\n";
  }
  out += "uniform int u_light_count;\nvec3 direct_e_over_pi_all(vec3 position, vec3 normal) {\n";
  out += "  vec3 e = direct_e_over_pi_0(position, normal);\n";
  for (std::size_t i = 1; i < slots; ++i)
    out += "  if (u_light_count > " + std::to_string(i) + ") e += direct_e_over_pi_" + std::to_string(i) +
           "(position, normal);\n";
  return out + "  return e;\n}\n";
}

// Adds one light's ld (u_ld) to the sum of the lights before it (u_sum; u_first: none), texel by
// texel in the ld layout.
const char* const kLdSumFrag = R"(uniform highp sampler2D u_ld;
uniform highp sampler2D u_sum;
uniform int u_first;
layout(location = 0) out vec4 o_ld;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 v = texelFetch(u_ld, p, 0);
  if (u_first == 0) v += texelFetch(u_sum, p, 0);
  o_ld = v;
}
)";

// Texture units of the scene program: u_shadow_0 and the material, atlas and probe samplers take
// 0..8 (assign_sampler_units, in this order), the other lights' shadow maps from 9 on.
constexpr int kFirstExtraShadowUnit = 9;
int shadow_unit(std::size_t light) { return light == 0 ? 0 : kFirstExtraShadowUnit + int(light) - 1; }

Mesh back_side(const Mesh& mesh) {
  Mesh back = mesh;
  back.name += " (back side)";
  for (std::size_t t = 0; t + 2 < back.indices.size(); t += 3)
    std::swap(back.indices[t + 1], back.indices[t + 2]);
  for (glm::vec3& n : back.normal) n = -n;
  for (glm::vec4& t : back.tangent) t = -t;
  return back;
}

void append_sphere(std::vector<MappedVertex>& out, float radius) {
  const int rings = 8, segments = 16;
  auto at = [&](int r, int s) {
    const float th = 3.14159265f * float(r) / float(rings), ph = 6.2831853f * float(s) / float(segments);
    MappedVertex v;
    v.normal = glm::vec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
    v.position = radius * v.normal;
    return v;
  };
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s)
      for (auto [dr, ds] : {std::pair{0, 0}, {1, 0}, {0, 1}, {0, 1}, {1, 0}, {1, 1}})
        out.push_back(at(r + dr, s + ds));
}

}  // namespace

Status gl_error_status(const platform::GlFunctions& gl, const std::string& what) {
  const GLenum e = gl.glGetError();
  if (e == GL_NO_ERROR) return Status::success();
  while (gl.glGetError() != GL_NO_ERROR) {  // only the first error is reported
  }
  return Status::error(e == GL_OUT_OF_MEMORY ? ErrorCode::resource_limit : ErrorCode::internal_error,
                       "renderer: " + what + ": " + platform::gl_error_name(e) +
                           (e == GL_OUT_OF_MEMORY ? " (the GL driver could not allocate it)" : ""));
}

Result<std::vector<MappedMesh>> map_back_sides(const DemoScene& scene, const Level& level) {
  DemoScene backs;
  std::vector<int> original;
  for (std::size_t i = 0; i < scene.meshes.size(); ++i) {
    const Mesh& mesh = scene.meshes[i];
    if (mesh.dynamic || mesh.clutter >= 0 || mesh.material < 0 ||
        std::size_t(mesh.material) >= scene.materials.size() ||
        !scene.materials[std::size_t(mesh.material)].double_sided)
      continue;
    backs.meshes.push_back(back_side(mesh));
    original.push_back(int(i));
  }
  if (backs.meshes.empty()) return std::vector<MappedMesh>();
  Result<std::vector<MappedMesh>> mapped = map_to_proxies(backs, level);
  if (!mapped.ok())
    return Status::error(mapped.status().code(),
                         "back sides of double-sided meshes: " + mapped.status().message());
  for (MappedMesh& m : mapped.value()) m.mesh = original[std::size_t(m.mesh)];
  return mapped;
}

Status buffer_data_checked(const platform::GlFunctions& gl, GLenum target, std::size_t bytes,
                           const void* data, const std::string& what) {
  if (Status s = gl_error_status(gl, "before allocating " + what); !s.ok()) return s;
  if (bytes > std::size_t(std::numeric_limits<GLsizeiptr>::max()))
    return Status::error(ErrorCode::resource_limit, "renderer: " + what + ": " + std::to_string(bytes) +
                                                        " bytes do not fit in GLsizeiptr");
  gl.glBufferData(target, GLsizeiptr(bytes), data, GL_STATIC_DRAW);
  return gl_error_status(gl, "glBufferData of " + std::to_string(bytes) + " bytes for " + what);
}

struct SceneRenderer::Impl {
  const platform::GlFunctions& gl;
  explicit Impl(const platform::GlFunctions& g) : gl(g) {}
  ~Impl() {
    for (GLuint p : programs) gl.glDeleteProgram(p);
    if (!framebuffers.empty()) gl.glDeleteFramebuffers(GLsizei(framebuffers.size()), framebuffers.data());
    if (!textures.empty()) gl.glDeleteTextures(GLsizei(textures.size()), textures.data());
    if (!buffers.empty()) gl.glDeleteBuffers(GLsizei(buffers.size()), buffers.data());
    if (vao) gl.glDeleteVertexArrays(1, &vao);
    if (empty_vao) gl.glDeleteVertexArrays(1, &empty_vao);
  }
  GLuint texture(GLenum format, int w, int h) {
    const GLuint t = platform::create_texture(gl, format, w, h);
    textures.push_back(t);
    return t;
  }
  GLint loc(GLuint program, const char* name) const { return gl.glGetUniformLocation(program, name); }
  // The camera image's light.glsl uniforms per light slot (light_slots_glsl, the ld pass's
  // light model), the slots in use and the light marker's colour.
  std::vector<gles::LightUniforms> scene_lighting;
  GLint light_count = -1, marker_rgb = -1;
  void set_lighting(const FrameState& frame) const {
    for (std::size_t i = 0; i < frame.lights.size(); ++i)
      scene_lighting[i].set(gl, frame.lights[i], shadow_cube(i));
    gl.glUniform1i(light_count, int(frame.lights.size()));
  }

  GLint shadow_view_proj = -1, shadow_offset = -1, tonemap_exposure = -1;
  struct SceneUniforms {
    GLint view_proj = -1, output = -1, probe_grid = -1, probe_cell = -1, probe_f = -1, offset = -1,
          base_color = -1, has_normal_map = -1, normal_scale = -1, use_vector = -1, dynamic = -1,
          emissive = -1, has_base_map = -1, clutter = -1;
  } su;

  std::vector<GLuint> programs, framebuffers, textures, buffers;
  GLuint vao = 0, empty_vao = 0, vbo = 0;
  GLuint shadow_program = 0, scene_program = 0, tonemap_program = 0, gather_program = 0, sum_program = 0;
  std::vector<GLuint> shadow_cubes;  // one per light slot
  // Directional lights: the orthographic map in the cube's +X face (render_shadows), per slot;
  // the drawn geometry's bounds it covers (static, and dynamic before its frame's offset).
  std::vector<gles::GpuShadowCube> directional_shadow;
  std::vector<std::uint8_t> slot_directional;
  glm::vec3 static_lo{0.0f}, static_hi{0.0f}, dynamic_lo{0.0f}, dynamic_hi{0.0f};
  bool has_static = false, has_dynamic = false;
  // A directional light's orthographic shadow map: the bounding sphere of the static geometry
  // and of the dynamic geometry at this frame's offset, seen along `direction` from outside it.
  gles::GpuShadowCube directional_shadow_map(const FrameState& frame, glm::vec3 direction) const {
    glm::vec3 lo = static_lo, hi = static_hi;
    if (has_dynamic) {
      const glm::vec3 dlo = dynamic_lo + frame.dynamic_offset, dhi = dynamic_hi + frame.dynamic_offset;
      lo = has_static ? glm::min(lo, dlo) : dlo;
      hi = has_static ? glm::max(hi, dhi) : dhi;
    }
    const glm::vec3 centre = 0.5f * (lo + hi);
    const float radius = 0.5f * glm::length(hi - lo) + 0.05f;
    const glm::vec3 dir = glm::length(direction) > 1e-6f ? glm::normalize(direction) : glm::vec3(0, -1, 0);
    const glm::vec3 up = std::abs(dir.y) < 0.99f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
    gles::GpuShadowCube cube;
    cube.near_plane = 0.05f;
    cube.far_plane = 2.0f * radius + 0.1f;
    const glm::mat4 view = glm::lookAt(centre - dir * (radius + 0.05f), centre, up);
    cube.directional_view_proj =
        glm::ortho(-radius, radius, -radius, radius, cube.near_plane, cube.far_plane) * view;
    return cube;
  }
  gles::GpuShadowCube shadow_cube(std::size_t light) const {
    if (light < slot_directional.size() && slot_directional[light]) return directional_shadow[light];
    return {light < shadow_cubes.size() ? shadow_cubes[light] : 0, kShadowNear, kShadowFar};
  }
  std::vector<std::array<GLuint, 6>> shadow_fbos;  // their faces
  int shadow_size = 0;
  // add_ld: two RGBA32F targets in the ld layout, written in turn; `sum` the last written.
  std::array<GLuint, 2> sum_texture{}, sum_fbo{};
  int sum = -1;
  TextureSize sum_layout;
  GLint sum_first = -1;
  std::size_t samples = 0;
  GLuint color = 0, depth = 0, scene_fbo = 0, display = 0, display_fbo = 0;
  std::array<GLuint, 5> own_atlas{};  // CPU-computed atlas (0) and vector atlases (1..4)
  GLuint own_probes = 0;              // CPU-computed probe volume (upload_probes)
  std::size_t own_probe_texels = 0;
  int atlas_width = 0, atlas_height = 0;
  std::vector<DrawRange> draws;
  DrawRange light_marker;
  std::vector<Material> materials;
  std::vector<GLuint> material_normal;  // texture per material, 0 = none
  std::vector<GLuint> material_base;    // base colour texture (sRGB) per material, 0 = none
  std::vector<float> readback;
  // DRT clutter: per object its atlas (cell -> texel, padding) and its res x res RGBA32F
  // lightmap texture; the offset of its texels in the concatenated clutter lightmap.
  std::vector<std::shared_ptr<const ClutterMeshData>> clutter_mesh;
  std::vector<GLuint> clutter_texture;
  // gather_clutter_lightmap: per mesh object a framebuffer over its texture and its RG32I
  // cell -> clutter atlas texel map (set_clutter_atlas_layout); 0 for box objects.
  std::vector<GLuint> clutter_fbo, clutter_cell_texel;
  std::vector<std::size_t> clutter_offset;
  std::size_t clutter_floats = 0;
  bool clutter_uploaded = false;
};

SceneRenderer::SceneRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SceneRenderer::~SceneRenderer() = default;

Result<std::unique_ptr<SceneRenderer>> SceneRenderer::create(const platform::GlFunctions& gl,
                                                             bool gles_context, const DemoScene& scene,
                                                             std::span<const MappedMesh> mapped,
                                                             const Level& level,
                                                             std::span<const float> albedo,
                                                             const RendererOptions& options) {
  if (options.width < 1 || options.height < 1 || options.width > 8192 || options.height > 8192)
    return Status::error(ErrorCode::invalid_argument, "renderer: image size must be 1..8192 on each side");
  if (options.shadow_size < 16 || options.shadow_size > 4096)
    return Status::error(ErrorCode::invalid_argument, "renderer: shadow map size must be 16..4096");
  if (albedo.size() != 3 * std::size_t(level.sample_count))
    return Status::error(ErrorCode::invalid_argument, "renderer: albedo has the wrong size for the level");
  if (gles_context && !platform::has_gl_extension(gl, "GL_EXT_color_buffer_float"))
    return Status::error(
        ErrorCode::resource_limit,
        "renderer: this GLES context cannot render to float targets (no EXT_color_buffer_float)");
  if (scene.lights.size() > kMaxDemoLights)
    return Status::error(ErrorCode::invalid_argument,
                         "renderer: the scene has " + std::to_string(scene.lights.size()) +
                             " lights; the renderer draws at most " + std::to_string(kMaxDemoLights) +
                             " (kMaxDemoLights: a shadow cube map each)");
  // One slot for a scene without lights: the program and its uniforms stay the same.
  const std::size_t slots = std::max<std::size_t>(scene.lights.size(), 1);
  while (gl.glGetError() != GL_NO_ERROR) {
  }
  auto impl = std::make_unique<Impl>(gl);
  Impl& m = *impl;
  m.atlas_width = level.atlas.width;
  m.atlas_height = level.atlas.height;

  // ---- programs ----
  auto program = [&](const char* name, std::initializer_list<const char*> vs,
                     std::initializer_list<const char*> fs, GLuint& out) -> Status {
    Result<GLuint> p = platform::build_program(gl, name, vs, fs);
    if (!p.ok()) return p.status();
    out = p.value();
    m.programs.push_back(out);
    return Status::success();
  };
  if (Status s = program("demo shadow", {kHeader, kShadowVert}, {kHeader, kShadowFrag}, m.shadow_program);
      !s.ok())
    return s;
  const std::string lights_glsl = light_slots_glsl(slots);
  if (Status s = program("demo scene", {kHeader, kSceneVert}, {kHeader, lights_glsl.c_str(), kSceneFrag},
                         m.scene_program);
      !s.ok())
    return s;
  if (Status s = program("demo ld sum", {kHeader, kFullscreenVert}, {kHeader, kLdSumFrag}, m.sum_program);
      !s.ok())
    return s;
  if (Status s =
          program("demo tonemap", {kHeader, kFullscreenVert}, {kHeader, kTonemapFrag}, m.tonemap_program);
      !s.ok())
    return s;
  if (Status s = program("demo clutter gather", {kHeader, kFullscreenVert}, {kHeader, kClutterGatherFrag},
                         m.gather_program);
      !s.ok())
    return s;
  gl.glUseProgram(m.scene_program);
  platform::assign_sampler_units(gl, m.scene_program,
                                 {"u_shadow_0", "u_normal_map", "u_atlas", "u_vector0", "u_vector1",
                                  "u_vector2", "u_vector3", "u_base_map", "u_probes"});
  for (std::size_t i = 1; i < slots; ++i)
    platform::set_int(gl, m.scene_program, light_slot_name("u_shadow", i).c_str(), shadow_unit(i));
  for (std::size_t i = 0; i < slots; ++i) {
    const auto loc = [&](const char* name) {
      return m.loc(m.scene_program, light_slot_name(name, i).c_str());
    };
    gles::LightUniforms u;
    u.position = loc("u_light_position"), u.rgb = loc("u_light_rgb"), u.radius = loc("u_light_radius"),
    u.spot_direction = loc("u_spot_direction"), u.spot_cos = loc("u_spot_cos"),
    u.shadow_params = loc("u_shadow_params"), u.falloff_floor = loc("u_falloff_floor_d2"),
    u.shadow_matrix = loc("u_shadow_matrix");
    gl.glUniform1f(u.falloff_floor, 0.0f);  // the camera image shades points, not texels
    m.scene_lighting.push_back(u);
  }
  m.light_count = m.loc(m.scene_program, "u_light_count");
  m.marker_rgb = m.loc(m.scene_program, "u_marker_rgb");
  gl.glUseProgram(m.sum_program);
  platform::assign_sampler_units(gl, m.sum_program, {"u_ld", "u_sum"});
  m.sum_first = m.loc(m.sum_program, "u_first");
  gl.glUseProgram(m.tonemap_program);
  platform::assign_sampler_units(gl, m.tonemap_program, {"u_linear"});
  gl.glUseProgram(m.gather_program);
  platform::assign_sampler_units(gl, m.gather_program, {"u_cell_texel", "u_clutter_atlas"});
  m.shadow_view_proj = m.loc(m.shadow_program, "u_view_proj");
  m.shadow_offset = m.loc(m.shadow_program, "u_offset");
  m.tonemap_exposure = m.loc(m.tonemap_program, "u_exposure");
  {
    const GLuint p = m.scene_program;
    m.su = {m.loc(p, "u_view_proj"),    m.loc(p, "u_output"),         m.loc(p, "u_probe_grid"),
            m.loc(p, "u_probe_cell"),   m.loc(p, "u_probe_f"),        m.loc(p, "u_offset"),
            m.loc(p, "u_base_color"),   m.loc(p, "u_has_normal_map"), m.loc(p, "u_normal_scale"),
            m.loc(p, "u_use_vector"),   m.loc(p, "u_dynamic"),        m.loc(p, "u_emissive"),
            m.loc(p, "u_has_base_map"), m.loc(p, "u_clutter")};
  }
  gl.glUseProgram(0);

  // ---- geometry ----
  // One vertex buffer: the mapped meshes, the dynamic and clutter meshes and the light marker.
  // Its size was checked before anything was expanded (map_to_proxies, on the exact count of
  // the cut meshes), and is checked here on what was mapped; reserved once, so that growing it
  // never holds twice the buffer.
  // Double-sided static meshes: their back sides as meshes of their own, mapped onto the proxy
  // faces they face, drawn culled like their fronts.
  Result<std::vector<MappedMesh>> backs = map_back_sides(scene, level);
  if (!backs.ok()) return Status::error(backs.status().code(), "renderer: " + backs.status().message());
  std::size_t drawn_corners = drawn_corner_count(scene, mapped);
  for (const MappedMesh& mm : backs.value())
    drawn_corners = saturating_add(drawn_corners, mm.vertices.size());
  if (const std::string problem = vertex_buffer_problem(drawn_corners); !problem.empty())
    return Status::error(ErrorCode::resource_limit, "renderer: " + problem);
  const auto double_sided = [&](const Mesh& mesh) {
    return mesh.material >= 0 && std::size_t(mesh.material) < scene.materials.size() &&
           scene.materials[std::size_t(mesh.material)].double_sided;
  };
  std::vector<MappedVertex> vertices;
  vertices.reserve(drawn_corners);
  for (const bool front : {true, false})
    for (const MappedMesh& mm : front ? mapped : std::span<const MappedMesh>(backs.value())) {
      if (mm.mesh < 0 || std::size_t(mm.mesh) >= scene.meshes.size())
        return Status::error(ErrorCode::invalid_argument, "renderer: a mapped mesh names mesh " +
                                                              std::to_string(mm.mesh) + ", the scene has " +
                                                              std::to_string(scene.meshes.size()));
      DrawRange d{GLint(vertices.size()), GLsizei(mm.vertices.size()),
                  scene.meshes[std::size_t(mm.mesh)].material, false};
      d.casts_shadow = front;
      vertices.insert(vertices.end(), mm.vertices.begin(), mm.vertices.end());
      m.draws.push_back(d);
    }
  auto next = [&] { return GLint(vertices.size()); };
  for (const Mesh& mesh : scene.meshes) {
    if (!mesh.dynamic) continue;
    DrawRange d{next(), 0, mesh.material, true};
    d.both_sides = double_sided(mesh);
    for (std::uint32_t i : mesh.indices) {
      if (i >= mesh.position.size() || i >= mesh.normal.size())
        return Status::error(ErrorCode::invalid_argument,
                             "renderer: mesh '" + mesh.name + "': index out of range");
      MappedVertex v;
      v.position = mesh.position[i];
      v.normal = mesh.normal[i];
      if (i < mesh.uv.size()) v.uv = mesh.uv[i];
      vertices.push_back(v);
    }
    d.count = next() - d.first;
    m.draws.push_back(d);
  }
  // Clutter meshes: their lightmap coordinates are TEXCOORD_1 in texels of their object's
  // res x res clutter lightmap (x + 0.5 a texel centre, as the level atlas's).
  for (const Mesh& mesh : scene.meshes) {
    if (mesh.dynamic || mesh.clutter < 0) continue;
    if (std::size_t(mesh.clutter) >= scene.clutter.size() || !scene.clutter[std::size_t(mesh.clutter)].mesh)
      return Status::error(ErrorCode::invalid_argument,
                           "renderer: mesh '" + mesh.name + "' names clutter object " +
                               std::to_string(mesh.clutter) +
                               ", which is not a mesh clutter object of the scene");
    if (mesh.lightmap_uv.size() != mesh.position.size())
      return Status::error(ErrorCode::invalid_argument,
                           "renderer: clutter mesh '" + mesh.name + "' needs one lightmap UV per vertex");
    const float res = float(scene.clutter[std::size_t(mesh.clutter)].mesh->atlas.res);
    DrawRange d{next(), 0, mesh.material, false, mesh.clutter};
    d.both_sides = double_sided(mesh);
    for (std::uint32_t i : mesh.indices) {
      if (i >= mesh.position.size() || i >= mesh.normal.size())
        return Status::error(ErrorCode::invalid_argument,
                             "renderer: mesh '" + mesh.name + "': index out of range");
      MappedVertex v;
      v.position = mesh.position[i];
      v.normal = mesh.normal[i];
      if (i < mesh.uv.size()) v.uv = mesh.uv[i];
      if (i < mesh.tangent.size()) v.tangent = mesh.tangent[i];
      v.lightmap = mesh.lightmap_uv[i] * res;
      vertices.push_back(v);
    }
    d.count = next() - d.first;
    m.draws.push_back(d);
  }
  for (const ClutterObject& object : scene.clutter) {
    m.clutter_offset.push_back(m.clutter_floats);
    m.clutter_floats += 3 * std::size_t(clutter_texel_count(object));
    m.clutter_mesh.push_back(object.mesh);
    // Box clutter has no mesh to draw; it keeps no texture.
    m.clutter_texture.push_back(
        object.mesh ? m.texture(GL_RGBA32F, object.mesh->atlas.res, object.mesh->atlas.res) : 0);
  }
  m.light_marker.first = next();
  append_sphere(vertices, 1.0f);
  m.light_marker.count = next() - m.light_marker.first;
  for (const DrawRange& d : m.draws)
    if (d.material < 0 || std::size_t(d.material) >= scene.materials.size())
      return Status::error(ErrorCode::invalid_argument, "renderer: a mesh uses material " +
                                                            std::to_string(d.material) + ", the scene has " +
                                                            std::to_string(scene.materials.size()));
  // The bounds a directional light's orthographic shadow map covers.
  for (const DrawRange& d : m.draws) {
    glm::vec3& lo = d.dynamic ? m.dynamic_lo : m.static_lo;
    glm::vec3& hi = d.dynamic ? m.dynamic_hi : m.static_hi;
    bool& any = d.dynamic ? m.has_dynamic : m.has_static;
    for (GLint i = d.first; i < d.first + GLint(d.count); ++i) {
      const glm::vec3 p = vertices[std::size_t(i)].position;
      lo = any ? glm::min(lo, p) : p;
      hi = any ? glm::max(hi, p) : p;
      any = true;
    }
  }
  gl.glGenVertexArrays(1, &m.vao);
  gl.glGenVertexArrays(1, &m.empty_vao);
  gl.glGenBuffers(1, &m.vbo);
  m.buffers.push_back(m.vbo);
  gl.glBindVertexArray(m.vao);
  gl.glBindBuffer(GL_ARRAY_BUFFER, m.vbo);
  if (Status s = buffer_data_checked(gl, GL_ARRAY_BUFFER, vertices.size() * sizeof(MappedVertex),
                                     vertices.data(), "the vertex buffer");
      !s.ok())
    return s;
  const struct {
    GLuint location;
    GLint size;
    std::size_t offset;
  } attributes[] = {{0, 3, offsetof(MappedVertex, position)}, {1, 3, offsetof(MappedVertex, normal)},
                    {2, 4, offsetof(MappedVertex, tangent)},  {3, 2, offsetof(MappedVertex, uv)},
                    {4, 2, offsetof(MappedVertex, lightmap)}, {5, 3, offsetof(MappedVertex, face_u)},
                    {6, 3, offsetof(MappedVertex, face_v)}};
  for (const auto& a : attributes) {
    gl.glEnableVertexAttribArray(a.location);
    gl.glVertexAttribPointer(a.location, a.size, GL_FLOAT, GL_FALSE, sizeof(MappedVertex),
                             reinterpret_cast<const void*>(a.offset));
  }
  gl.glBindVertexArray(0);

  // ---- material textures (normal maps, mipmapped) ----
  m.materials = scene.materials;
  std::vector<GLuint> image_texture(scene.images.size(), 0);
  for (std::size_t i = 0; i < scene.images.size(); ++i) {
    const Image& img = scene.images[i];
    if (img.width < 1 || img.height < 1 ||
        img.rgba.size() != 4 * std::size_t(img.width) * std::size_t(img.height))
      return Status::error(ErrorCode::invalid_argument,
                           "renderer: image '" + img.name + "' has no valid RGBA8 data");
    GLuint t = 0;
    gl.glGenTextures(1, &t);
    m.textures.push_back(t);
    int levels = 1;
    while ((std::max(img.width, img.height) >> levels) > 0) ++levels;
    gl.glBindTexture(GL_TEXTURE_2D, t);
    gl.glTexStorage2D(GL_TEXTURE_2D, levels, GL_RGBA8, img.width, img.height);
    if (Status s = gl_error_status(gl, "allocating the texture of image '" + img.name + "' (" +
                                           std::to_string(img.width) + " x " + std::to_string(img.height) +
                                           " RGBA8, mipmapped)");
        !s.ok())
      return s;
    gl.glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, img.width, img.height, GL_RGBA, GL_UNSIGNED_BYTE,
                       img.rgba.data());
    gl.glGenerateMipmap(GL_TEXTURE_2D);
    gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    image_texture[i] = t;
  }
  for (const Material& mat : m.materials)
    m.material_base.push_back(mat.base_color_texture >= 0 &&
                                      std::size_t(mat.base_color_texture) < image_texture.size()
                                  ? image_texture[std::size_t(mat.base_color_texture)]
                                  : 0);
  for (const Material& mat : m.materials)
    m.material_normal.push_back(mat.normal_texture >= 0 &&
                                        std::size_t(mat.normal_texture) < image_texture.size()
                                    ? image_texture[std::size_t(mat.normal_texture)]
                                    : 0);

  // ---- shadow cube maps (depth, hardware comparison), one per light ----
  m.shadow_size = options.shadow_size;
  for (std::size_t light = 0; light < slots; ++light) {
    GLuint cube = 0;
    gl.glGenTextures(1, &cube);
    m.textures.push_back(cube);
    m.shadow_cubes.push_back(cube);
    gl.glBindTexture(GL_TEXTURE_CUBE_MAP, cube);
    gl.glTexStorage2D(GL_TEXTURE_CUBE_MAP, 1, GL_DEPTH_COMPONENT24, m.shadow_size, m.shadow_size);
    if (Status s = gl_error_status(gl, "allocating the shadow cube map of light " + std::to_string(light));
        !s.ok())
      return s;
    gl.glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    gl.glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    gl.glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    gl.glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
    gl.glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    gl.glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    std::array<GLuint, 6>& faces = m.shadow_fbos.emplace_back();
    for (int f = 0; f < 6; ++f) {
      GLuint fbo = 0;
      gl.glGenFramebuffers(1, &fbo);
      m.framebuffers.push_back(fbo);
      gl.glBindFramebuffer(GL_FRAMEBUFFER, fbo);
      gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT,
                                GLenum(GL_TEXTURE_CUBE_MAP_POSITIVE_X + f), cube, 0);
      const GLenum none = GL_NONE;
      gl.glDrawBuffers(1, &none);
      gl.glReadBuffer(GL_NONE);
      if (gl.glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        return Status::error(ErrorCode::resource_limit,
                             "renderer: the shadow cube map (DEPTH_COMPONENT24) is not renderable");
      faces[std::size_t(f)] = fbo;
    }
  }

  // ---- camera targets ----
  m.color = m.texture(GL_RGBA32F, options.width, options.height);
  m.depth = m.texture(GL_DEPTH_COMPONENT24, options.width, options.height);
  Result<GLuint> scene_fbo = platform::create_framebuffer(gl, "demo scene", {m.color}, "RGBA32F");
  if (!scene_fbo.ok()) return scene_fbo.status();
  m.scene_fbo = scene_fbo.value();
  m.framebuffers.push_back(m.scene_fbo);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, m.scene_fbo);
  gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, m.depth, 0);
  if (gl.glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    return Status::error(ErrorCode::resource_limit,
                         "renderer: RGBA32F colour + DEPTH_COMPONENT24 is not renderable");
  m.display = m.texture(GL_RGBA8, options.width, options.height);
  Result<GLuint> display_fbo = platform::create_framebuffer(gl, "demo display", {m.display}, "RGBA8");
  if (!display_fbo.ok()) return display_fbo.status();
  m.display_fbo = display_fbo.value();
  m.framebuffers.push_back(m.display_fbo);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  m.readback.resize(4 * std::size_t(options.width) * std::size_t(options.height));
  if (Status s = gl_error_status(gl, "creating the sample images and render targets"); !s.ok()) return s;
  std::unique_ptr<SceneRenderer> r(new SceneRenderer(std::move(impl)));
  r->options_ = options;
  return r;
}

namespace {

void bind_texture(const platform::GlFunctions& gl, int unit, GLenum target, GLuint texture) {
  gl.glActiveTexture(GLenum(GL_TEXTURE0 + unit));
  gl.glBindTexture(target, texture);
}

}  // namespace

Status SceneRenderer::render_shadows(const FrameState& frame) {
  Impl& m = *impl_;
  const platform::GlFunctions& gl = m.gl;
  if (frame.lights.size() > m.shadow_cubes.size())
    return Status::error(ErrorCode::invalid_argument,
                         "renderer: the frame has " + std::to_string(frame.lights.size()) +
                             " lights, the renderer was made for " + std::to_string(m.shadow_cubes.size()));
  static const glm::vec3 dirs[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  static const glm::vec3 ups[6] = {{0, -1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {0, -1, 0}, {0, -1, 0}};
  const glm::mat4 proj = glm::perspective(glm::radians(90.0f), 1.0f, kShadowNear, kShadowFar);
  gl.glUseProgram(m.shadow_program);
  gl.glBindVertexArray(m.vao);
  gl.glEnable(GL_DEPTH_TEST);
  gl.glDepthFunc(GL_LESS);
  gl.glDepthMask(GL_TRUE);
  gl.glDisable(GL_BLEND);
  gl.glDisable(GL_CULL_FACE);
  gl.glEnable(GL_POLYGON_OFFSET_FILL);
  gl.glPolygonOffset(1.5f, 2.0f);
  gl.glViewport(0, 0, m.shadow_size, m.shadow_size);
  const GLint vp = m.shadow_view_proj, off = m.shadow_offset;
  m.slot_directional.assign(m.shadow_cubes.size(), 0);
  m.directional_shadow.resize(m.shadow_cubes.size());
  for (std::size_t light = 0; light < frame.lights.size(); ++light) {
    if (frame.lights[light].directional) {
      // An orthographic map over the drawn geometry's bounding sphere, in the +X face.
      m.slot_directional[light] = 1;
      gles::GpuShadowCube& cube = m.directional_shadow[light];
      cube = m.directional_shadow_map(frame, frame.lights[light].spot_direction);
      cube.texture = m.shadow_cubes[light];
      gl.glBindFramebuffer(GL_FRAMEBUFFER, m.shadow_fbos[light][0]);
      gl.glClearDepthf(1.0f);
      gl.glClear(GL_DEPTH_BUFFER_BIT);
      gl.glUniformMatrix4fv(vp, 1, GL_FALSE, glm::value_ptr(cube.directional_view_proj));
      for (const DrawRange& d : m.draws) {
        if (!d.casts_shadow) continue;
        const glm::vec3 o = d.dynamic ? frame.dynamic_offset : glm::vec3(0.0f);
        gl.glUniform3f(off, o.x, o.y, o.z);
        gl.glDrawArrays(GL_TRIANGLES, d.first, d.count);
      }
      continue;
    }
    const glm::vec3 at = frame.lights[light].position;
    for (int f = 0; f < 6; ++f) {
      gl.glBindFramebuffer(GL_FRAMEBUFFER, m.shadow_fbos[light][std::size_t(f)]);
      gl.glClearDepthf(1.0f);
      gl.glClear(GL_DEPTH_BUFFER_BIT);
      const glm::mat4 view_proj = proj * glm::lookAt(at, at + dirs[f], ups[f]);
      gl.glUniformMatrix4fv(vp, 1, GL_FALSE, glm::value_ptr(view_proj));
      for (const DrawRange& d : m.draws) {
        if (!d.casts_shadow) continue;
        const glm::vec3 o = d.dynamic ? frame.dynamic_offset : glm::vec3(0.0f);
        gl.glUniform3f(off, o.x, o.y, o.z);
        gl.glDrawArrays(GL_TRIANGLES, d.first, d.count);
      }
    }
  }
  gl.glDisable(GL_POLYGON_OFFSET_FILL);
  gl.glBindVertexArray(0);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return gl_error_status(gl, "shadow pass");
}

gles::GpuShadowCube SceneRenderer::shadow_cube(std::size_t light) const { return impl_->shadow_cube(light); }

std::size_t SceneRenderer::light_slots() const { return impl_->shadow_cubes.size(); }

Status SceneRenderer::add_ld(GLuint ld_texture, TextureSize layout, bool first) {
  Impl& m = *impl_;
  const platform::GlFunctions& gl = m.gl;
  if (!ld_texture || layout.width < 1 || layout.height < 1)
    return Status::error(ErrorCode::invalid_argument, "renderer: add_ld needs an ld texture and its layout");
  if (m.sum_texture[0] && (layout.width != m.sum_layout.width || layout.height != m.sum_layout.height))
    return Status::error(ErrorCode::invalid_argument, "renderer: add_ld: the ld layout changed");
  if (!first && m.sum < 0)
    return Status::error(ErrorCode::invalid_argument, "renderer: add_ld: no sum to add to (first light?)");
  if (!m.sum_texture[0]) {
    m.sum_layout = layout;
    for (std::size_t i = 0; i < 2; ++i) {
      m.sum_texture[i] = m.texture(GL_RGBA32F, layout.width, layout.height);
      Result<GLuint> fbo = platform::create_framebuffer(gl, "demo ld sum", {m.sum_texture[i]}, "RGBA32F");
      if (!fbo.ok()) return fbo.status();
      m.sum_fbo[i] = fbo.value();
      m.framebuffers.push_back(fbo.value());
    }
  }
  const int target = first ? 0 : 1 - m.sum;
  gl.glDisable(GL_DEPTH_TEST);
  gl.glDisable(GL_BLEND);
  gl.glDisable(GL_CULL_FACE);
  gl.glDisable(GL_SCISSOR_TEST);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, m.sum_fbo[std::size_t(target)]);
  gl.glViewport(0, 0, layout.width, layout.height);
  gl.glUseProgram(m.sum_program);
  gl.glUniform1i(m.sum_first, first ? 1 : 0);
  bind_texture(gl, 0, GL_TEXTURE_2D, ld_texture);
  bind_texture(gl, 1, GL_TEXTURE_2D, first ? 0 : m.sum_texture[std::size_t(m.sum)]);
  gl.glBindVertexArray(m.empty_vao);
  gl.glDrawArrays(GL_TRIANGLES, 0, 3);
  gl.glBindVertexArray(0);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gl.glUseProgram(0);
  gl.glActiveTexture(GL_TEXTURE0);
  m.sum = target;
  return gl_error_status(gl, "summing the lights' ld");
}

GLuint SceneRenderer::summed_ld() const {
  return impl_->sum < 0 ? 0 : impl_->sum_texture[std::size_t(impl_->sum)];
}

Status SceneRenderer::read_summed_ld(std::span<float> ld) {
  Impl& m = *impl_;
  const platform::GlFunctions& gl = m.gl;
  if (m.sum < 0) return Status::error(ErrorCode::invalid_argument, "renderer: no ld summed yet");
  const std::size_t texels = std::size_t(m.sum_layout.width) * std::size_t(m.sum_layout.height);
  if (ld.size() > 3 * texels)
    return Status::error(ErrorCode::invalid_argument, "renderer: ld has " + std::to_string(ld.size()) +
                                                          " floats, more than the summed texture's " +
                                                          std::to_string(3 * texels));
  if (m.readback.size() < 4 * texels) m.readback.resize(4 * texels);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, m.sum_fbo[std::size_t(m.sum)]);
  gl.glReadBuffer(GL_COLOR_ATTACHMENT0);
  gl.glPixelStorei(GL_PACK_ALIGNMENT, 4);
  gl.glReadPixels(0, 0, m.sum_layout.width, m.sum_layout.height, GL_RGBA, GL_FLOAT, m.readback.data());
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (Status s = gl_error_status(gl, "reading the summed ld"); !s.ok()) return s;
  // As GlesDirectLight::read_ld: the CPU runtime rejects NaN and negative ld.
  for (std::size_t i = 0; i < ld.size(); ++i) {
    const float v = m.readback[4 * (i / 3) + i % 3];
    ld[i] = v > 0.0f ? std::min(v, kMaxLightValue) : 0.0f;
  }
  return Status::success();
}

Result<GLuint> SceneRenderer::upload_atlas(std::span<const float> atlas_rgb, int slot) {
  Impl& m = *impl_;
  const platform::GlFunctions& gl = m.gl;
  const std::size_t texels = std::size_t(m.atlas_width) * std::size_t(m.atlas_height);
  if (atlas_rgb.size() != 3 * texels)
    return Status::error(ErrorCode::invalid_argument, "renderer: the atlas has the wrong size for the level");
  if (slot < 0 || slot > 4)
    return Status::error(ErrorCode::invalid_argument, "renderer: atlas slot must be 0..4");
  GLuint& target = m.own_atlas[std::size_t(slot)];
  if (!target) target = m.texture(GL_RGBA32F, std::max(m.atlas_width, 1), std::max(m.atlas_height, 1));
  if (m.readback.size() < 4 * texels) m.readback.resize(4 * texels);
  for (std::size_t i = 0; i < texels; ++i) {
    for (std::size_t c = 0; c < 3; ++c) m.readback[4 * i + c] = atlas_rgb[3 * i + c];
    m.readback[4 * i + 3] = 1.0f;
  }
  gl.glBindTexture(GL_TEXTURE_2D, target);
  gl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, m.atlas_width, m.atlas_height, GL_RGBA, GL_FLOAT,
                     m.readback.data());
  if (Status s = gl_error_status(gl, "uploading the atlas"); !s.ok()) return s;
  return target;
}

Result<GLuint> SceneRenderer::upload_probes(std::span<const float> world_probes) {
  Impl& m = *impl_;
  const platform::GlFunctions& gl = m.gl;
  if (world_probes.empty() || world_probes.size() % 27 != 0)
    return Status::error(ErrorCode::invalid_argument,
                         "renderer: the probe volume has " + std::to_string(world_probes.size()) +
                             " floats, not a positive multiple of 27 (SH9 RGB per probe)");
  const std::size_t texels = world_probes.size() / 3;
  if (m.own_probes && texels != m.own_probe_texels)
    return Status::error(ErrorCode::invalid_argument, "renderer: the probe volume changed size from " +
                                                          std::to_string(3 * m.own_probe_texels) + " to " +
                                                          std::to_string(world_probes.size()) + " floats");
  const std::size_t width = std::min(texels, kProbeTextureWidth), height = (texels + width - 1) / width;
  if (height > kProbeTextureWidth)
    return Status::error(ErrorCode::resource_limit, "renderer: the probe volume (" + std::to_string(texels) +
                                                        " texels) does not fit a 2048 x 2048 texture");
  if (!m.own_probes) {
    m.own_probes = m.texture(GL_RGBA32F, int(width), int(height));
    m.own_probe_texels = texels;
  }
  if (m.readback.size() < 4 * width * height) m.readback.resize(4 * width * height);
  std::fill(m.readback.begin(), m.readback.begin() + std::ptrdiff_t(4 * width * height), 0.0f);
  for (std::size_t i = 0; i < texels; ++i) {
    for (std::size_t c = 0; c < 3; ++c) m.readback[4 * i + c] = world_probes[3 * i + c];
    m.readback[4 * i + 3] = 1.0f;
  }
  gl.glBindTexture(GL_TEXTURE_2D, m.own_probes);
  gl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, GLsizei(width), GLsizei(height), GL_RGBA, GL_FLOAT,
                     m.readback.data());
  if (Status s = gl_error_status(gl, "uploading the probe volume"); !s.ok()) return s;
  return m.own_probes;
}

Status SceneRenderer::set_clutter_atlas_layout(const ClutterAtlasTexel& atlas_texel) {
  Impl& m = *impl_;
  const platform::GlFunctions& gl = m.gl;
  m.clutter_fbo.assign(m.clutter_mesh.size(), 0);
  m.clutter_cell_texel.assign(m.clutter_mesh.size(), 0);
  std::vector<std::int32_t> cell_texel;
  for (std::size_t k = 0; k < m.clutter_mesh.size(); ++k) {
    if (!m.clutter_mesh[k]) continue;
    const ClutterMeshAtlas& atlas = m.clutter_mesh[k]->atlas;
    const std::size_t cells = std::size_t(atlas.res) * std::size_t(atlas.res);
    cell_texel.assign(2 * cells, -1);
    for (std::size_t c = 0; c < cells; ++c) {
      const std::int32_t t = atlas.cell_texel[c];
      if (t < 0) continue;
      const std::array<int, 2> at = atlas_texel(k, std::uint32_t(t));
      if (at[0] < 0 || at[1] < 0)
        return Status::error(ErrorCode::invalid_argument,
                             "renderer: the backend places texel " + std::to_string(t) +
                                 " of clutter object " + std::to_string(k) + " nowhere in its clutter atlas");
      cell_texel[2 * c] = at[0], cell_texel[2 * c + 1] = at[1];
    }
    // The padding ring copies its neighbours (as upload_clutter_lightmap does), in order.
    for (const auto& [to, from] : atlas.padding)
      for (std::size_t i = 0; i < 2; ++i)
        cell_texel[2 * std::size_t(to) + i] = cell_texel[2 * std::size_t(from) + i];
    m.clutter_cell_texel[k] = m.texture(GL_RG32I, atlas.res, atlas.res);
    gl.glBindTexture(GL_TEXTURE_2D, m.clutter_cell_texel[k]);
    gl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, atlas.res, atlas.res, GL_RG_INTEGER, GL_INT,
                       cell_texel.data());
    Result<GLuint> fbo =
        platform::create_framebuffer(gl, "demo clutter lightmap", {m.clutter_texture[k]}, "RGBA32F");
    if (!fbo.ok()) return fbo.status();
    m.clutter_fbo[k] = fbo.value();
    m.framebuffers.push_back(fbo.value());
  }
  return gl_error_status(gl, "creating the clutter lightmap gather");
}

Status SceneRenderer::gather_clutter_lightmap(GLuint clutter_atlas) {
  Impl& m = *impl_;
  const platform::GlFunctions& gl = m.gl;
  if (m.clutter_fbo.size() != m.clutter_mesh.size())
    return Status::error(ErrorCode::invalid_argument,
                         "renderer: gather_clutter_lightmap needs set_clutter_atlas_layout first");
  if (!clutter_atlas)
    return Status::error(ErrorCode::invalid_argument, "renderer: no clutter atlas texture given");
  gl.glDisable(GL_DEPTH_TEST);
  gl.glDisable(GL_BLEND);
  gl.glDisable(GL_CULL_FACE);
  gl.glDisable(GL_SCISSOR_TEST);
  gl.glUseProgram(m.gather_program);
  gl.glBindVertexArray(m.empty_vao);
  bind_texture(gl, 1, GL_TEXTURE_2D, clutter_atlas);
  for (std::size_t k = 0; k < m.clutter_mesh.size(); ++k) {
    if (!m.clutter_fbo[k]) continue;
    const int res = m.clutter_mesh[k]->atlas.res;
    gl.glBindFramebuffer(GL_FRAMEBUFFER, m.clutter_fbo[k]);
    gl.glViewport(0, 0, res, res);
    bind_texture(gl, 0, GL_TEXTURE_2D, m.clutter_cell_texel[k]);
    gl.glDrawArrays(GL_TRIANGLES, 0, 3);
  }
  gl.glBindVertexArray(0);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gl.glUseProgram(0);
  m.clutter_uploaded = true;
  return gl_error_status(gl, "gathering the clutter lightmaps");
}

Status SceneRenderer::upload_clutter_lightmap(std::span<const float> clutter_lightmap) {
  Impl& m = *impl_;
  const platform::GlFunctions& gl = m.gl;
  if (clutter_lightmap.size() != m.clutter_floats)
    return Status::error(ErrorCode::invalid_argument,
                         "renderer: the clutter lightmap has " + std::to_string(clutter_lightmap.size()) +
                             " floats, the scene's clutter " + std::to_string(m.clutter_floats));
  for (std::size_t k = 0; k < m.clutter_mesh.size(); ++k) {
    if (!m.clutter_mesh[k]) continue;
    const ClutterMeshAtlas& atlas = m.clutter_mesh[k]->atlas;
    const std::size_t cells = std::size_t(atlas.res) * std::size_t(atlas.res);
    if (m.readback.size() < 4 * cells) m.readback.resize(4 * cells);
    std::fill(m.readback.begin(), m.readback.begin() + std::ptrdiff_t(4 * cells), 0.0f);
    const float* src = clutter_lightmap.data() + m.clutter_offset[k];
    for (std::size_t c = 0; c < cells; ++c) {
      const std::int32_t t = atlas.cell_texel[c];
      if (t < 0) continue;
      for (std::size_t ch = 0; ch < 3; ++ch) m.readback[4 * c + ch] = src[3 * std::size_t(t) + ch];
      m.readback[4 * c + 3] = 1.0f;
    }
    // The ring around the charts copies its neighbours, so bilinear taps at chart borders
    // never read black.
    for (const auto& [to, from] : atlas.padding)
      for (std::size_t ch = 0; ch < 4; ++ch) m.readback[4 * to + ch] = m.readback[4 * from + ch];
    gl.glBindTexture(GL_TEXTURE_2D, m.clutter_texture[k]);
    gl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, atlas.res, atlas.res, GL_RGBA, GL_FLOAT, m.readback.data());
  }
  m.clutter_uploaded = true;
  return gl_error_status(gl, "uploading the clutter lightmaps");
}

glm::mat4 SceneRenderer::view_projection(const DemoCamera& cam) const {
  return glm::perspective(cam.yfov, float(options_.width) / float(options_.height), cam.znear, cam.zfar) *
         glm::lookAt(cam.position, cam.target, cam.up);
}

Status SceneRenderer::render_image(const FrameState& frame, std::span<float> linear_rgb,
                                   std::span<std::uint8_t> srgb8) {
  Impl& m = *impl_;
  const platform::GlFunctions& gl = m.gl;
  const std::size_t pixels = std::size_t(options_.width) * std::size_t(options_.height);
  if (linear_rgb.size() != 3 * pixels || srgb8.size() != 3 * pixels)
    return Status::error(ErrorCode::invalid_argument, "renderer: output buffers have the wrong size");
  if (!frame.atlas) return Status::error(ErrorCode::invalid_argument, "renderer: no lightmap atlas given");
  if (m.clutter_floats > 0 && !m.clutter_uploaded)
    return Status::error(ErrorCode::invalid_argument,
                         "renderer: the scene has clutter but no clutter lightmap was uploaded");
  if (frame.lights.size() > m.shadow_cubes.size())
    return Status::error(ErrorCode::invalid_argument,
                         "renderer: the frame has " + std::to_string(frame.lights.size()) +
                             " lights, the renderer was made for " + std::to_string(m.shadow_cubes.size()));
  const glm::mat4 view_proj = view_projection(frame.camera);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, m.scene_fbo);
  gl.glViewport(0, 0, options_.width, options_.height);
  gl.glEnable(GL_DEPTH_TEST);
  gl.glDepthFunc(GL_LESS);
  gl.glDepthMask(GL_TRUE);
  // Walls are one-sided: two blocks sharing a wall each draw their own face of it, coplanar
  // and facing apart, and only the one facing the camera may win. Single-sided glTF materials
  // are culled too; double-sided ones are drawn as two culled sides or without culling (DrawRange).
  gl.glEnable(GL_CULL_FACE);
  gl.glCullFace(GL_BACK);
  gl.glDisable(GL_BLEND);
  gl.glClearColor(0.0f, 0.0f, 0.0f, 1.0f);
  gl.glClearDepthf(1.0f);
  gl.glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  const GLuint p = m.scene_program;
  gl.glUseProgram(p);
  m.set_lighting(frame);
  gl.glUniformMatrix4fv(m.su.view_proj, 1, GL_FALSE, glm::value_ptr(view_proj));
  gl.glUniform1i(m.su.output, int(frame.output == OutputMode::combined ? 0
                                  : frame.output == OutputMode::direct ? 1
                                                                       : 2));
  const bool vector =
      std::all_of(frame.vector_atlas.begin(), frame.vector_atlas.end(), [](GLuint t) { return t != 0; });
  const ProbeCell& cell = frame.probe_cell;
  gl.glUniform1i(m.su.probe_grid, frame.probes ? frame.probe_grid : 0);
  gl.glUniform4i(m.su.probe_cell, int(cell.block), cell.i0.x, cell.i0.y, cell.i0.z);
  gl.glUniform3f(m.su.probe_f, float(cell.f.x), float(cell.f.y), float(cell.f.z));
  bind_texture(gl, 8, GL_TEXTURE_2D, frame.probes);
  for (std::size_t i = 0; i < m.shadow_cubes.size(); ++i)
    bind_texture(gl, shadow_unit(i), GL_TEXTURE_CUBE_MAP, m.shadow_cubes[i]);
  bind_texture(gl, 2, GL_TEXTURE_2D, frame.atlas);
  for (int i = 0; i < 4; ++i)
    bind_texture(gl, 3 + i, GL_TEXTURE_2D, vector ? frame.vector_atlas[std::size_t(i)] : frame.atlas);
  gl.glBindVertexArray(m.vao);
  const GLint u_offset = m.su.offset, u_base = m.su.base_color, u_nm = m.su.has_normal_map,
              u_scale = m.su.normal_scale, u_vec = m.su.use_vector, u_dyn = m.su.dynamic,
              u_emissive = m.su.emissive, u_base_tex = m.su.has_base_map, u_clutter = m.su.clutter;
  gl.glUniform1i(u_emissive, 0);
  gl.glUniform1i(u_clutter, 0);
  for (const DrawRange& d : m.draws) {
    const Material& mat = m.materials[std::size_t(d.material)];
    const GLuint normal_map = m.material_normal[std::size_t(d.material)];
    const GLuint base_map = m.material_base[std::size_t(d.material)];
    const glm::vec3 o = d.dynamic ? frame.dynamic_offset : glm::vec3(0.0f);
    if (d.both_sides)
      gl.glDisable(GL_CULL_FACE);
    else
      gl.glEnable(GL_CULL_FACE);
    gl.glUniform3f(u_offset, o.x, o.y, o.z);
    gl.glUniform3f(u_base, mat.base_color.x, mat.base_color.y, mat.base_color.z);
    gl.glUniform1i(u_nm, normal_map != 0);
    gl.glUniform1f(u_scale, mat.normal_scale);
    gl.glUniform1i(u_vec, vector && normal_map != 0 && !d.dynamic);
    gl.glUniform1i(u_dyn, d.dynamic);
    // Always rebound (0 when absent, never sampled then): a unit must not keep a texture of
    // another type from an earlier pass, such as the GLES backend's RGBA32UI signals.
    bind_texture(gl, 1, GL_TEXTURE_2D, normal_map);
    bind_texture(gl, 7, GL_TEXTURE_2D, base_map);
    gl.glUniform1i(u_base_tex, base_map != 0);
    if (d.clutter >= 0) {
      // Clutter draws come last: the atlas unit is not needed again this pass.
      gl.glUniform1i(u_vec, 0);
      gl.glUniform1i(u_clutter, 1);
      bind_texture(gl, 2, GL_TEXTURE_2D, m.clutter_texture[std::size_t(d.clutter)]);
    }
    gl.glDrawArrays(GL_TRIANGLES, d.first, d.count);
  }
  gl.glUniform1i(u_clutter, 0);
  gl.glEnable(GL_CULL_FACE);
  // The lights themselves, small bright spheres (scaled through the offset trick: radius 1 mesh).
  gl.glUniform1i(u_emissive, 1);
  gl.glUniform3f(u_offset, 0.0f, 0.0f, 0.0f);
  for (const gles::GpuLight& light : frame.lights) {
    if (light.directional) continue;  // the sun has no place
    const glm::mat4 marker = view_proj * glm::translate(glm::mat4(1.0f), light.position) *
                             glm::scale(glm::mat4(1.0f), glm::vec3(std::max(light.radius, 0.01f)));
    gl.glUniformMatrix4fv(m.su.view_proj, 1, GL_FALSE, glm::value_ptr(marker));
    gl.glUniform3f(m.marker_rgb, light.rgb.x, light.rgb.y, light.rgb.z);
    gl.glDrawArrays(GL_TRIANGLES, m.light_marker.first, m.light_marker.count);
  }
  gl.glBindVertexArray(0);
  gl.glDisable(GL_CULL_FACE);
  if (Status s = gl_error_status(gl, "scene pass"); !s.ok()) return s;
  gl.glPixelStorei(GL_PACK_ALIGNMENT, 4);
  gl.glReadBuffer(GL_COLOR_ATTACHMENT0);
  gl.glReadPixels(0, 0, options_.width, options_.height, GL_RGBA, GL_FLOAT, m.readback.data());
  for (std::size_t i = 0; i < pixels; ++i)
    for (std::size_t c = 0; c < 3; ++c) linear_rgb[3 * i + c] = m.readback[4 * i + c];

  // Tone mapping into RGBA8, read back top row first.
  gl.glDisable(GL_DEPTH_TEST);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, m.display_fbo);
  gl.glUseProgram(m.tonemap_program);
  gl.glUniform1f(m.tonemap_exposure, frame.exposure);
  bind_texture(gl, 0, GL_TEXTURE_2D, m.color);
  gl.glBindVertexArray(m.empty_vao);
  gl.glDrawArrays(GL_TRIANGLES, 0, 3);
  gl.glBindVertexArray(0);
  gl.glPixelStorei(GL_PACK_ALIGNMENT, 1);
  auto* rgba = reinterpret_cast<std::uint8_t*>(m.readback.data());
  gl.glReadBuffer(GL_COLOR_ATTACHMENT0);
  gl.glReadPixels(0, 0, options_.width, options_.height, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
  for (int y = 0; y < options_.height; ++y)
    for (int x = 0; x < options_.width; ++x) {
      const std::size_t src =
          4 * (std::size_t(options_.height - 1 - y) * std::size_t(options_.width) + std::size_t(x));
      const std::size_t dst = 3 * (std::size_t(y) * std::size_t(options_.width) + std::size_t(x));
      for (std::size_t c = 0; c < 3; ++c) srgb8[dst + c] = rgba[src + c];
    }
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gl.glUseProgram(0);
  return gl_error_status(gl, "tone mapping");
}

}  // namespace modrt::demo
