// SPDX-License-Identifier: MIT
#include "host_gltf.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <utility>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

// Debian's libtinygltf is compiled (stb_image and nlohmann-json inside): the header only.
#include <tiny_gltf.h>

namespace modrt::host {
namespace {

struct Failure : std::runtime_error {
  using std::runtime_error::runtime_error;
};
[[noreturn]] void fail(const std::string& message) { throw Failure(message); }
std::string num(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}
std::string num(std::size_t v) { return std::to_string(v); }
std::string num(int v) { return std::to_string(v); }

// candela -> W/sr at 555 nm, modrt-demo's kCandelaToWattsPerSr.
constexpr double kCandelaToWattsPerSr = 1.0 / 683.0;

class Loader {
 public:
  Loader(const tinygltf::Model& model, HostScene& scene) : m_(model), s_(scene) {}
  void load();

 private:
  // Elements of an accessor as floats (float components only: the host reads no quantized data).
  std::vector<float> floats(int accessor, int components, const std::string& what) const;
  std::vector<std::uint32_t> indices(int accessor, std::size_t vertices, const std::string& what) const;
  const unsigned char* element_base(const tinygltf::Accessor& a, std::size_t element_size,
                                    std::size_t& stride, const std::string& what) const;
  void add_node_mesh(int node, const glm::dmat4& world, bool dynamic, int clutter);
  void read_materials();
  std::string node_label(int node) const {
    const std::string& n = m_.nodes[std::size_t(node)].name;
    return "node " + num(node) + (n.empty() ? std::string() : " ('" + n + "')");
  }

  const tinygltf::Model& m_;
  HostScene& s_;
  bool have_camera_ = false, have_light_ = false, have_dynamic_ = false;
};

glm::dmat4 local_matrix(const tinygltf::Node& n) {
  if (n.matrix.size() == 16) {
    glm::dmat4 m(1.0);
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) m[c][r] = n.matrix[std::size_t(4 * c + r)];  // column-major
    return m;
  }
  glm::dmat4 t(1.0), r(1.0), s(1.0);
  if (n.translation.size() == 3) t[3] = glm::dvec4(n.translation[0], n.translation[1], n.translation[2], 1.0);
  if (n.rotation.size() == 4)
    r = glm::dmat4(glm::mat3_cast(glm::dquat(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2])));
  if (n.scale.size() == 3)
    s = glm::dmat4(glm::dvec4(n.scale[0], 0, 0, 0), glm::dvec4(0, n.scale[1], 0, 0),
                   glm::dvec4(0, 0, n.scale[2], 0), glm::dvec4(0, 0, 0, 1));
  return t * r * s;
}

const unsigned char* Loader::element_base(const tinygltf::Accessor& a, std::size_t element_size,
                                          std::size_t& stride, const std::string& what) const {
  if (a.sparse.isSparse) fail(what + ": sparse accessors are not supported");
  if (a.bufferView < 0 || std::size_t(a.bufferView) >= m_.bufferViews.size())
    fail(what + ": accessor without a valid bufferView");
  const tinygltf::BufferView& v = m_.bufferViews[std::size_t(a.bufferView)];
  if (v.buffer < 0 || std::size_t(v.buffer) >= m_.buffers.size())
    fail(what + ": bufferView without a buffer");
  const tinygltf::Buffer& b = m_.buffers[std::size_t(v.buffer)];
  stride = v.byteStride ? v.byteStride : element_size;
  if (stride < element_size) fail(what + ": byteStride " + num(stride) + " is below the element size");
  const std::size_t count = a.count;
  const std::size_t need = a.byteOffset + (count ? (count - 1) * stride + element_size : 0);
  if (v.byteOffset > b.data.size() || v.byteLength > b.data.size() - v.byteOffset || need > v.byteLength)
    fail(what + ": " + num(count) + " elements of " + num(element_size) + " bytes do not fit in bufferView " +
         num(a.bufferView));
  return b.data.data() + v.byteOffset + a.byteOffset;
}

std::vector<float> Loader::floats(int index, int components, const std::string& what) const {
  if (index < 0 || std::size_t(index) >= m_.accessors.size())
    fail(what + ": accessor " + num(index) + " does not exist");
  const tinygltf::Accessor& a = m_.accessors[std::size_t(index)];
  if (tinygltf::GetNumComponentsInType(std::uint32_t(a.type)) != components)
    fail(what + ": accessor " + num(index) + " has " +
         num(tinygltf::GetNumComponentsInType(std::uint32_t(a.type))) + " components, expected " +
         num(components));
  if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
    fail(what + ": accessor " + num(index) + " has componentType " + num(a.componentType) +
         "; modrt-embed-host reads float (5126) vertex data only");
  std::size_t stride = 0;
  const unsigned char* p = element_base(a, 4 * std::size_t(components), stride, what);
  std::vector<float> out(a.count * std::size_t(components));
  for (std::size_t i = 0; i < a.count; ++i) {
    std::memcpy(&out[i * std::size_t(components)], p + i * stride, 4 * std::size_t(components));
    for (int c = 0; c < components; ++c)
      if (!std::isfinite(out[i * std::size_t(components) + std::size_t(c)]))
        fail(what + ": element " + num(i) + " is not finite");
  }
  return out;
}

std::vector<std::uint32_t> Loader::indices(int index, std::size_t vertices, const std::string& what) const {
  std::vector<std::uint32_t> out;
  if (index < 0) {
    for (std::size_t i = 0; i < vertices; ++i) out.push_back(std::uint32_t(i));
    return out;
  }
  if (std::size_t(index) >= m_.accessors.size()) fail(what + ": accessor " + num(index) + " does not exist");
  const tinygltf::Accessor& a = m_.accessors[std::size_t(index)];
  const int ct = a.componentType;
  const std::size_t size = ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE    ? 1
                           : ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ? 2
                           : ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT   ? 4
                                                                          : 0;
  if (size == 0 || a.type != TINYGLTF_TYPE_SCALAR)
    fail(what + ": indices must be unsigned byte, short or int scalars");
  std::size_t stride = 0;
  const unsigned char* p = element_base(a, size, stride, what);
  out.resize(a.count);
  for (std::size_t i = 0; i < a.count; ++i) {
    std::uint32_t v = 0;
    if (size == 1) v = p[i * stride];
    if (size == 2) {
      std::uint16_t s = 0;
      std::memcpy(&s, p + i * stride, 2);
      v = s;
    }
    if (size == 4) std::memcpy(&v, p + i * stride, 4);
    if (v >= vertices)
      fail(what + ": index " + num(i) + " is " + num(std::size_t(v)) + ", the primitive has " +
           num(vertices) + " vertices");
    out[i] = v;
  }
  if (out.size() % 3 != 0) fail(what + ": " + num(out.size()) + " indices, not a multiple of 3");
  return out;
}

void Loader::read_materials() {
  for (std::size_t i = 0; i < m_.images.size(); ++i) {
    const tinygltf::Image& img = m_.images[i];
    const std::string what = "image " + num(i);
    if (img.width < 1 || img.height < 1 || img.image.empty()) fail(what + ": no decoded pixels");
    if (img.bits != 8 && img.bits != 16)
      fail(what + ": " + num(img.bits) + " bits per channel (8 or 16 expected)");
    const int comp = img.component, bytes = img.bits / 8;
    if (comp < 1 || comp > 4 ||
        img.image.size() != std::size_t(img.width) * std::size_t(img.height) * std::size_t(comp * bytes))
      fail(what + ": pixel data of the wrong size");
    HostImage out;
    out.width = img.width, out.height = img.height;
    out.rgba.resize(4 * std::size_t(img.width) * std::size_t(img.height));
    for (std::size_t p = 0; p < std::size_t(img.width) * std::size_t(img.height); ++p) {
      auto at = [&](int c) {  // 16-bit samples keep their high byte (little-endian storage)
        return img
            .image[(p * std::size_t(comp) + std::size_t(c)) * std::size_t(bytes) + std::size_t(bytes - 1)];
      };
      const std::uint8_t g = at(0);
      out.rgba[4 * p + 0] = comp >= 3 ? at(0) : g;
      out.rgba[4 * p + 1] = comp >= 3 ? at(1) : g;
      out.rgba[4 * p + 2] = comp >= 3 ? at(2) : g;
      out.rgba[4 * p + 3] = comp == 4 ? at(3) : comp == 2 ? at(1) : 255;
    }
    s_.images.push_back(std::move(out));
  }
  auto image_of = [&](int texture, const std::string& what) {
    if (texture < 0) return -1;
    if (std::size_t(texture) >= m_.textures.size())
      fail(what + ": texture " + num(texture) + " does not exist");
    const int source = m_.textures[std::size_t(texture)].source;
    if (source < 0 || std::size_t(source) >= s_.images.size())
      fail(what + ": texture " + num(texture) + " has no image source");
    return source;
  };
  for (std::size_t i = 0; i < m_.materials.size(); ++i) {
    const tinygltf::Material& mat = m_.materials[i];
    const std::string what =
        "material " + num(i) + (mat.name.empty() ? std::string() : " ('" + mat.name + "')");
    HostMaterial h;
    h.name = mat.name;
    const std::vector<double>& f = mat.pbrMetallicRoughness.baseColorFactor;
    if (f.size() >= 3) h.base_color = glm::vec3(float(f[0]), float(f[1]), float(f[2]));
    for (int c = 0; c < 3; ++c)
      if (!(h.base_color[c] >= 0.0f && h.base_color[c] <= 1.0f))
        fail(what + ": baseColorFactor " + num(double(h.base_color[c])) + " is not in [0, 1]");
    h.base_color_image =
        image_of(mat.pbrMetallicRoughness.baseColorTexture.index, what + " baseColorTexture");
    h.normal_image = image_of(mat.normalTexture.index, what + " normalTexture");
    h.normal_scale = float(mat.normalTexture.scale);
    if (mat.pbrMetallicRoughness.baseColorTexture.texCoord != 0 || mat.normalTexture.texCoord != 0)
      s_.warnings.push_back(what + ": a texture on another TEXCOORD set than 0 is drawn with TEXCOORD_0");
    s_.materials.push_back(h);
  }
  // Primitives without a material.
  HostMaterial fallback;
  fallback.name = "glTF default";
  s_.materials.push_back(fallback);
}

void Loader::add_node_mesh(int node_index, const glm::dmat4& world, bool dynamic, int clutter) {
  const tinygltf::Node& node = m_.nodes[std::size_t(node_index)];
  if (std::size_t(node.mesh) >= m_.meshes.size())
    fail(node_label(node_index) + ": mesh " + num(node.mesh) + " does not exist");
  const tinygltf::Mesh& mesh = m_.meshes[std::size_t(node.mesh)];
  const glm::dmat3 linear(world);
  const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(linear));
  const bool mirrored = glm::determinant(linear) < 0.0;
  if (!(std::abs(glm::determinant(linear)) > 1e-30))
    fail(node_label(node_index) + ": its transform is singular");
  for (std::size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
    const tinygltf::Primitive& prim = mesh.primitives[pi];
    const std::string what = node_label(node_index) + ": mesh " + num(node.mesh) + " primitive " + num(pi);
    if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1)
      fail(what + ": primitive mode " + num(prim.mode) +
           " is not supported by modrt-embed-host (TRIANGLES only)");
    auto attribute = [&](const char* name) {
      auto it = prim.attributes.find(name);
      return it == prim.attributes.end() ? -1 : it->second;
    };
    if (attribute("POSITION") < 0) fail(what + ": missing POSITION attribute");
    const std::vector<float> pos = floats(attribute("POSITION"), 3, what + " POSITION");
    const std::size_t n = pos.size() / 3;
    auto optional = [&](const char* name, int components) {
      std::vector<float> v;
      if (attribute(name) >= 0) {
        v = floats(attribute(name), components, what + " " + name);
        if (v.size() / std::size_t(components) != n)
          fail(what + ": " + name + " has " + num(v.size() / std::size_t(components)) +
               " elements, POSITION " + num(n));
      }
      return v;
    };
    const std::vector<float> nrm = optional("NORMAL", 3), uv = optional("TEXCOORD_0", 2),
                             uv1 = optional("TEXCOORD_1", 2), tan = optional("TANGENT", 4);
    std::vector<std::uint32_t> idx = indices(prim.indices, n, what);
    HostMesh out;
    out.name = node.name + (pi > 0 ? " #" + num(pi) : std::string());
    out.material = prim.material >= 0 ? prim.material : int(s_.materials.size()) - 1;
    if (std::size_t(out.material) >= s_.materials.size())
      fail(what + ": material " + num(prim.material) + " does not exist");
    out.dynamic = dynamic;
    out.clutter = clutter;
    if (clutter >= 0 && uv1.empty())
      fail(what + ": a clutter mesh (extras.modrt_clutter) needs its lightmap UVs in TEXCOORD_1");
    const bool normal_mapped = s_.materials[std::size_t(out.material)].normal_image >= 0;
    // Without NORMAL: flat normals, a vertex per corner (glTF's rule), as modrt-demo.
    const bool split = nrm.empty();
    auto emit = [&](std::uint32_t v, const glm::vec3* flat) {
      const glm::dvec3 p = glm::dvec3(world * glm::dvec4(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2], 1.0));
      out.position.push_back(glm::vec3(p));
      if (flat) {
        out.normal.push_back(*flat);
      } else {
        const glm::dvec3 nn = normal_matrix * glm::dvec3(nrm[3 * v], nrm[3 * v + 1], nrm[3 * v + 2]);
        if (!(glm::length(nn) > 0.0)) fail(what + ": NORMAL " + num(std::size_t(v)) + " is zero");
        out.normal.push_back(glm::vec3(glm::normalize(nn)));
      }
      if (!uv.empty()) out.uv.push_back({uv[2 * v], uv[2 * v + 1]});
      if (!uv1.empty()) out.uv1.push_back({uv1[2 * v], uv1[2 * v + 1]});
      if (!tan.empty()) {
        glm::dvec3 t = linear * glm::dvec3(tan[4 * v], tan[4 * v + 1], tan[4 * v + 2]);
        t = glm::length(t) > 0.0 ? glm::normalize(t) : glm::dvec3(1, 0, 0);
        out.tangent.push_back(
            glm::vec4(glm::vec3(t), (mirrored ? -1.0f : 1.0f) * (tan[4 * v + 3] < 0 ? -1.0f : 1.0f)));
      }
    };
    for (std::size_t t = 0; t + 2 < idx.size(); t += 3) {
      std::uint32_t c[3] = {idx[t], idx[t + 1], idx[t + 2]};
      if (mirrored) std::swap(c[1], c[2]);  // stays counter-clockwise after a mirroring transform
      if (split) {
        const glm::vec3 a = glm::vec3(world *
                                      glm::dvec4(pos[3 * c[0]], pos[3 * c[0] + 1], pos[3 * c[0] + 2], 1.0)),
                        b = glm::vec3(world *
                                      glm::dvec4(pos[3 * c[1]], pos[3 * c[1] + 1], pos[3 * c[1] + 2], 1.0)),
                        d = glm::vec3(world *
                                      glm::dvec4(pos[3 * c[2]], pos[3 * c[2] + 1], pos[3 * c[2] + 2], 1.0));
        glm::vec3 fn = glm::cross(b - a, d - a);
        fn = glm::length(fn) > 0.0f ? glm::normalize(fn) : glm::vec3(0, 1, 0);
        for (std::uint32_t k : c) emit(k, &fn);
        for (int k = 0; k < 3; ++k)
          out.indices.push_back(std::uint32_t(out.position.size() - 3 + std::size_t(k)));
      } else {
        for (std::uint32_t k : c) out.indices.push_back(k);
      }
    }
    if (!split)
      for (std::uint32_t v = 0; v < n; ++v) emit(v, nullptr);
    if (normal_mapped && out.tangent.empty()) {
      if (out.uv.empty()) fail(what + ": a normal-mapped material needs TEXCOORD_0 (or TANGENT)");
      // Per-triangle UV gradients, accumulated per vertex, Gram-Schmidt against the normal; w
      // so that cross(n, t) w points up the image (glTF's convention).
      std::vector<glm::dvec3> tu(out.position.size(), glm::dvec3(0.0)),
          tv(out.position.size(), glm::dvec3(0.0));
      for (std::size_t t = 0; t + 2 < out.indices.size(); t += 3) {
        const std::uint32_t a = out.indices[t], b = out.indices[t + 1], c = out.indices[t + 2];
        const glm::dvec3 e1 = glm::dvec3(out.position[b] - out.position[a]),
                         e2 = glm::dvec3(out.position[c] - out.position[a]);
        const glm::dvec2 d1 = glm::dvec2(out.uv[b] - out.uv[a]), d2 = glm::dvec2(out.uv[c] - out.uv[a]);
        const double det = d1.x * d2.y - d2.x * d1.y;
        if (std::abs(det) < 1e-20) continue;
        const glm::dvec3 su = (e1 * d2.y - e2 * d1.y) / det, sv = (e2 * d1.x - e1 * d2.x) / det;
        for (std::uint32_t k : {a, b, c}) tu[k] += su, tv[k] += sv;
      }
      for (std::size_t v = 0; v < out.position.size(); ++v) {
        const glm::dvec3 nn(out.normal[v]);
        glm::dvec3 t = tu[v] - nn * glm::dot(nn, tu[v]);
        if (!(glm::length(t) > 1e-20)) t = std::abs(nn.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
        t = glm::normalize(t - nn * glm::dot(nn, t));
        // Up the image is decreasing v: -tv.
        const double w = glm::dot(glm::cross(nn, t), -tv[v]) < 0.0 ? -1.0 : 1.0;
        out.tangent.push_back(glm::vec4(glm::vec3(t), float(w)));
      }
    }
    s_.meshes.push_back(std::move(out));
  }
}

void Loader::load() {
  for (const std::string& ext : m_.extensionsRequired)
    if (ext != "KHR_lights_punctual")
      fail("the file requires extension " + ext + ", which modrt-embed-host does not support");
  read_materials();
  std::vector<int> roots;
  int scene_index = -1;
  if (m_.scenes.empty()) {
    std::vector<char> child(m_.nodes.size(), 0);
    for (const tinygltf::Node& n : m_.nodes)
      for (int c : n.children)
        if (c >= 0 && std::size_t(c) < child.size()) child[std::size_t(c)] = 1;
    for (std::size_t i = 0; i < m_.nodes.size(); ++i)
      if (!child[i]) roots.push_back(int(i));
  } else {
    scene_index = std::max(m_.defaultScene, 0);
    if (std::size_t(scene_index) >= m_.scenes.size()) fail("scene " + num(scene_index) + " does not exist");
    roots = m_.scenes[std::size_t(scene_index)].nodes;
    const tinygltf::Value& extras = m_.scenes[std::size_t(scene_index)].extras;
    if (extras.IsObject() && extras.Has("modrt_level")) {
      const tinygltf::Value& l = extras.Get("modrt_level");
      if (l.IsObject() && l.Has("proxy_walls")) {
        if (!l.Get("proxy_walls").IsBool())
          fail("scene " + num(scene_index) + ": extras.modrt_level.proxy_walls must be true or false");
        s_.proxy_walls = l.Get("proxy_walls").Get<bool>();
      }
    }
  }
  // Depth first, without recursion; a node reached twice (a cycle) is an error.
  std::vector<char> seen(m_.nodes.size(), 0);
  std::vector<std::pair<int, glm::dmat4>> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, glm::dmat4(1.0)});
  while (!stack.empty()) {
    const auto [index, parent] = stack.back();
    stack.pop_back();
    if (index < 0 || std::size_t(index) >= m_.nodes.size()) fail("node " + num(index) + " does not exist");
    if (seen[std::size_t(index)])
      fail(node_label(index) + " is reached twice (a cycle or a node with two parents)");
    seen[std::size_t(index)] = 1;
    const tinygltf::Node& node = m_.nodes[std::size_t(index)];
    const glm::dmat4 world = parent * local_matrix(node);
    for (auto it = node.children.rbegin(); it != node.children.rend(); ++it) stack.push_back({*it, world});
    const std::string label = node_label(index);
    bool block = false, draw_block = false, dynamic = false;
    int clutter = -1;
    if (node.extras.IsObject()) {
      if (node.extras.Has("modrt_block")) {
        const tinygltf::Value& b = node.extras.Get("modrt_block");
        block = b.IsObject() || (b.IsBool() && b.Get<bool>());
        if (b.IsObject() && b.Has("draw") && b.Get("draw").IsBool()) draw_block = b.Get("draw").Get<bool>();
      }
      if (node.extras.Has("modrt_dynamic")) {
        if (!node.extras.Get("modrt_dynamic").IsBool())
          fail(label + ": extras.modrt_dynamic must be true or false");
        dynamic = node.extras.Get("modrt_dynamic").Get<bool>();
      }
      if (node.extras.Has("modrt_clutter")) {
        const tinygltf::Value& c = node.extras.Get("modrt_clutter");
        if (!(c.IsBool() && !c.Get<bool>())) {
          if (node.mesh < 0) fail(label + ": extras.modrt_clutter: the node has no mesh");
          if (dynamic || block)
            fail(label + ": extras.modrt_clutter: a clutter node cannot also be dynamic or a proxy block");
          HostClutter h;
          h.name = node.name;
          const tinygltf::Mesh& mesh = m_.meshes.at(std::size_t(node.mesh));
          const int material = mesh.primitives.empty() ? -1 : mesh.primitives[0].material;
          h.albedo = material >= 0 && std::size_t(material) < s_.materials.size()
                         ? s_.materials[std::size_t(material)].base_color
                         : s_.materials.back().base_color;
          if (c.IsObject()) {
            if (c.Has("res")) {
              if (!c.Get("res").IsInt() || c.Get("res").Get<int>() < 1 || c.Get("res").Get<int>() > 1024)
                fail(label + ": extras.modrt_clutter.res must be an integer 1..1024");
              h.res = c.Get("res").Get<int>();
            }
            if (c.Has("albedo")) {
              const tinygltf::Value& a = c.Get("albedo");
              if (!a.IsArray() || a.ArrayLen() != 3)
                fail(label + ": extras.modrt_clutter.albedo must be [r, g, b]");
              for (int k = 0; k < 3; ++k) {
                if (!a.Get(k).IsNumber()) fail(label + ": extras.modrt_clutter.albedo must hold numbers");
                h.albedo[k] = float(a.Get(k).GetNumberAsDouble());
                if (!(h.albedo[k] >= 0.0f && h.albedo[k] <= 1.0f))
                  fail(label + ": extras.modrt_clutter.albedo[" + num(k) + "] is not in [0, 1]");
              }
            }
          } else if (!c.IsBool()) {
            fail(label + ": extras.modrt_clutter must be true or an object");
          }
          clutter = int(s_.clutter.size());
          s_.clutter.push_back(h);
        }
      }
    }
    if (dynamic && block) fail(label + ": a node cannot be both a proxy block and dynamic");
    if (node.camera >= 0 && !have_camera_) {
      if (std::size_t(node.camera) >= m_.cameras.size())
        fail(label + " refers to camera " + num(node.camera) + ", which does not exist");
      const tinygltf::Camera& c = m_.cameras[std::size_t(node.camera)];
      if (c.type != "perspective")
        fail(label + ": camera " + num(node.camera) + " is '" + c.type +
             "'; modrt-embed-host renders perspective cameras");
      if (!(c.perspective.yfov > 0.0 && c.perspective.yfov < 3.14159))
        fail(label + ": camera yfov must be in (0, pi)");
      if (!(c.perspective.znear > 0.0)) fail(label + ": camera znear must be > 0");
      if (c.perspective.zfar != 0.0 && !(c.perspective.zfar > c.perspective.znear))
        fail(label + ": camera zfar must be greater than znear");
      const glm::dmat3 r(world);
      const glm::dvec3 forward = r * glm::dvec3(0, 0, -1), up = r * glm::dvec3(0, 1, 0);
      if (!(glm::length(forward) > 1e-12) || !(glm::length(up) > 1e-12))
        fail(label + ": the camera's transform is singular");
      s_.camera.position = glm::vec3(world[3]);
      s_.camera.forward = glm::vec3(glm::normalize(forward));
      s_.camera.up = glm::vec3(glm::normalize(up));
      s_.camera.yfov = float(c.perspective.yfov);
      s_.camera.znear = float(c.perspective.znear);
      s_.camera.zfar = float(c.perspective.zfar);
      have_camera_ = true;
    }
    if (auto it = node.extensions.find("KHR_lights_punctual"); it != node.extensions.end()) {
      if (!it->second.IsObject() || !it->second.Has("light") || !it->second.Get("light").IsInt())
        fail(label + ": KHR_lights_punctual needs an integer \"light\"");
      const int li = it->second.Get("light").Get<int>();
      if (li < 0 || std::size_t(li) >= m_.lights.size())
        fail(label + ": light " + num(li) + " does not exist");
      const tinygltf::Light& l = m_.lights[std::size_t(li)];
      if (l.type != "point") {
        s_.warnings.push_back(label + ": light " + num(li) + " is a " + l.type +
                              " light; the scene mode renders one point light, skipped");
      } else if (have_light_) {
        s_.warnings.push_back(label + ": light " + num(li) +
                              ": a second point light, skipped (one is rendered)");
      } else {
        if (!(std::isfinite(l.intensity) && l.intensity >= 0.0))
          fail(label + ": light intensity must be finite and >= 0");
        if (!l.color.empty() && l.color.size() != 3) fail(label + ": light color must have 3 numbers");
        for (std::size_t k = 0; k < l.color.size(); ++k)
          if (!(std::isfinite(l.color[k]) && l.color[k] >= 0.0))
            fail(label + ": light color must be finite and >= 0");
        s_.light.position = glm::vec3(world[3]);
        if (!l.color.empty())
          s_.light.color = glm::vec3(float(l.color[0]), float(l.color[1]), float(l.color[2]));
        s_.light.intensity = float(l.intensity * kCandelaToWattsPerSr);
        have_light_ = true;
      }
    }
    if (node.mesh < 0 || (block && !draw_block)) continue;
    if (dynamic) {
      if (!have_dynamic_) have_dynamic_ = true, s_.dynamic_origin = glm::vec3(world[3]);
      glm::dmat4 relative = world;
      relative[3] -= glm::dvec4(glm::dvec3(s_.dynamic_origin), 0.0);
      add_node_mesh(index, relative, true, -1);
    } else {
      add_node_mesh(index, world, false, clutter);
    }
  }
  if (!have_camera_) fail("no camera: the scene mode renders from the first node with a perspective camera");
  if (!have_light_) fail("no point light: the scene mode needs a KHR_lights_punctual point light on a node");
  if (s_.camera.zfar == 0.0f) s_.camera.zfar = 100.0f;
}

}  // namespace

bool load_host_scene(const std::string& path, HostScene& scene, std::string& error) {
  scene = HostScene{};
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    error = path + ": cannot open the glTF file";
    return false;
  }
  char magic[4] = {};
  in.read(magic, 4);
  const bool binary = in.gcount() == 4 && std::memcmp(magic, "glTF", 4) == 0;
  in.close();
  tinygltf::TinyGLTF gltf;
  tinygltf::Model model;
  std::string err, warn;
  const bool ok = binary ? gltf.LoadBinaryFromFile(&model, &err, &warn, path)
                         : gltf.LoadASCIIFromFile(&model, &err, &warn, path);
  if (!ok) {
    error = path + ": tinygltf could not load the " + std::string(binary ? "glb" : "glTF") + " file: " + err;
    while (!error.empty() && (error.back() == '\n' || error.back() == ' ')) error.pop_back();
    return false;
  }
  if (!warn.empty()) scene.warnings.push_back(path + ": tinygltf: " + warn);
  try {
    Loader(model, scene).load();
  } catch (const Failure& f) {
    error = path + ": " + f.what();
    return false;
  } catch (const std::exception& e) {
    error = path + ": " + e.what();
    return false;
  }
  return true;
}

}  // namespace modrt::host
