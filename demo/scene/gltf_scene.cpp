// SPDX-License-Identifier: MIT
#include "gltf_scene.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <new>
#include <optional>
#include <utility>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>

// The Debian package ships tinygltf compiled (libtinygltf, with stb_image and nlohmann-json
// inside): the header is included without TINYGLTF_IMPLEMENTATION.
#include <tiny_gltf.h>

#include <nlohmann/json.hpp>

#include "default_scene.h"
#include "modrt/file_io.h"
#include "modrt/light_policy.h"
#include "modrt/precompute/clutter_mesh.h"
#include "modrt/precompute/level_json.h"
#include "modrt/reference_runtime.h"
#include "proxy_mapping.h"
#include "scene_import_glue.h"

namespace modrt::demo {
namespace fs = std::filesystem;

std::string gltf_sidecar_level_path(const std::string& gltf_path) {
  fs::path p(gltf_path);
  p.replace_extension(".level.json");
  return p.string();
}

namespace {

// Thrown inside the loader, turned into a Status (prefixed with the file) at the top.
struct LoadFailure {
  ErrorCode code;
  std::string message;
};

[[noreturn]] void fail(ErrorCode code, std::string message) { throw LoadFailure{code, std::move(message)}; }

std::string quote(const std::string& s) { return "'" + s + "'"; }
std::string num(std::size_t v) { return std::to_string(v); }
std::string num(int v) { return std::to_string(v); }

std::string fmt_double(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string short_double(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// The brightest light taken: intensity (W/sr) x max(1, brightest colour channel) within
// kMaxLightIntensity, the bound every parser of authored lights applies (light_policy.h).
bool light_intensity_allowed(double intensity, const glm::dvec3& color) {
  return light_brightness_allowed(intensity, color);
}

// tinygltf's warn/err texts are newline-separated sentences.
std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(start, end - start);
    while (!line.empty() && (line.back() == ' ' || line.back() == '\r')) line.pop_back();
    if (!line.empty()) lines.push_back(std::move(line));
    start = end + 1;
  }
  return lines;
}

std::string join_lines(const std::string& text) {
  std::string out;
  for (const std::string& l : split_lines(text)) out += (out.empty() ? "" : "; ") + l;
  return out;
}

const char* mode_name(int mode) {
  switch (mode) {
    case TINYGLTF_MODE_POINTS: return "POINTS";
    case TINYGLTF_MODE_LINE: return "LINES";
    case TINYGLTF_MODE_LINE_LOOP: return "LINE_LOOP";
    case TINYGLTF_MODE_LINE_STRIP: return "LINE_STRIP";
    case TINYGLTF_MODE_TRIANGLES: return "TRIANGLES";
    case TINYGLTF_MODE_TRIANGLE_STRIP: return "TRIANGLE_STRIP";
    case TINYGLTF_MODE_TRIANGLE_FAN: return "TRIANGLE_FAN";
    default: return "unknown";
  }
}

// ---- files ----

std::vector<unsigned char> read_file_capped(const std::string& path, std::size_t cap) {
  std::error_code ec;
  if (!fs::exists(path, ec)) fail(ErrorCode::io_error, "file not found");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) fail(ErrorCode::io_error, "cannot read the file: " + ec.message());
  if (size > cap)
    fail(ErrorCode::resource_limit,
         "the file is " + std::to_string(size) + " bytes, more than the limit of " + num(cap));
  std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(ErrorCode::io_error, "cannot open the file");
  in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  if (std::size_t(in.gcount()) != bytes.size()) fail(ErrorCode::io_error, "error while reading the file");
  return bytes;
}

struct LoaderContext {
  std::size_t max_file_bytes = 0;
  int max_image_side = 0;
};

// tinygltf's file reader, refusing external buffers and images beyond the size limit before
// it allocates them.
bool read_whole_file_capped(std::vector<unsigned char>* out, std::string* err, const std::string& filepath,
                            void* user) {
  const auto* ctx = static_cast<const LoaderContext*>(user);
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(filepath, ec);
  if (ec) {
    if (err) *err += "cannot read " + filepath + ": " + ec.message() + "\n";
    return false;
  }
  if (size > ctx->max_file_bytes) {
    if (err)
      *err += filepath + " is " + std::to_string(size) + " bytes, more than the limit of " +
              num(ctx->max_file_bytes) + "\n";
    return false;
  }
  return tinygltf::ReadWholeFile(out, err, filepath, nullptr);
}

// Deepest nesting of arrays and objects in JSON text (strings skipped). The JSON parsers
// below (nlohmann's DOM, tinygltf's value conversion) recurse per level, so a file nested
// thousands deep would overflow the stack; glTF itself needs fewer than ten levels.
std::size_t json_depth(const unsigned char* p, std::size_t n) {
  std::size_t depth = 0, deepest = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char c = p[i];
    if (in_string) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return deepest;
}

constexpr std::size_t kMaxJsonDepth = 256;

std::uint32_t le32(const unsigned char* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) |
         (std::uint32_t(p[3]) << 24);
}

std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
}

// Width and height from a PNG's IHDR or a JPEG's start-of-frame segment, read before stb
// decodes (and allocates) the image. Returns false when the bytes are neither PNG nor JPEG;
// w = h = 0 when the header is not found (stb then reports the corrupt file).
bool sniff_image(const unsigned char* bytes, int size, int* w, int* h) {
  *w = *h = 0;
  static const unsigned char png[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size >= 8 && std::memcmp(bytes, png, 8) == 0) {
    if (size >= 24 && std::memcmp(bytes + 12, "IHDR", 4) == 0) {
      *w = int(std::min<std::uint32_t>(be32(bytes + 16), 0x7fffffff));
      *h = int(std::min<std::uint32_t>(be32(bytes + 20), 0x7fffffff));
    }
    return true;
  }
  if (size >= 3 && bytes[0] == 0xff && bytes[1] == 0xd8 && bytes[2] == 0xff) {
    int i = 2;
    while (i + 9 < size) {
      if (bytes[i] != 0xff) break;
      const int marker = bytes[i + 1];
      if (marker == 0xff) {  // fill byte
        ++i;
        continue;
      }
      if (marker == 0x01 || (marker >= 0xd0 && marker <= 0xd9)) {  // markers without a length
        i += 2;
        continue;
      }
      const int length = (bytes[i + 2] << 8) | bytes[i + 3];
      const bool sof = marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
      if (sof) {
        *h = (bytes[i + 5] << 8) | bytes[i + 6];
        *w = (bytes[i + 7] << 8) | bytes[i + 8];
        break;
      }
      if (length < 2) break;
      i += 2 + length;
    }
    return true;
  }
  return false;
}

// A PNG's chunk list: every chunk's declared length fits in the bytes that follow it and its
// CRC-32 (the IEEE/zlib polynomial, modrt::crc32) matches, up to IEND. stb_image trusts
// declared IDAT lengths and reallocates its buffer to them before reading (an 85-byte file
// asked for 2 GB; found by fuzz_gltf), so a damaged chunk is refused before decoding.
bool png_chunks_intact(const unsigned char* bytes, int size, std::string* problem) {
  std::size_t at = 8;
  const std::size_t end = std::size_t(size);
  for (int chunk = 0;; ++chunk) {
    if (end - at < 12) {
      *problem = "PNG ends inside chunk " + num(chunk) + " (no IEND)";
      return false;
    }
    const std::uint32_t length = be32(bytes + at);
    if (length > end - at - 12) {
      *problem = "PNG chunk " + num(chunk) + " declares " + std::to_string(length) + " bytes, " +
                 num(end - at - 12) + " are left";
      return false;
    }
    const auto* body = reinterpret_cast<const std::byte*>(bytes + at + 4);
    if (crc32(std::span<const std::byte>(body, 4 + std::size_t(length))) != be32(bytes + at + 8 + length)) {
      *problem = "PNG chunk " + num(chunk) + " has a bad CRC (damaged file)";
      return false;
    }
    const bool iend = std::memcmp(bytes + at + 4, "IEND", 4) == 0;
    at += 12 + std::size_t(length);
    if (iend) return true;
  }
}

// Image decoding through tinygltf's stb loader, after checking the format and the size.
bool load_image_checked(tinygltf::Image* image, const int index, std::string* err, std::string* warn,
                        int req_width, int req_height, const unsigned char* bytes, int size, void* user) {
  const auto* ctx = static_cast<const LoaderContext*>(user);
  std::string label = "image " + num(index);
  if (!image->uri.empty())
    label += " (" + image->uri + ")";
  else if (!image->name.empty())
    label += " ('" + image->name + "')";
  int w = 0, h = 0;
  if (!sniff_image(bytes, size, &w, &h)) {
    if (err)
      *err += label + ": unsupported image format" +
              (image->mimeType.empty() ? std::string() : " (declared " + image->mimeType + ")") +
              "; glTF 2.0 images are PNG or JPEG\n";
    return false;
  }
  if (w > ctx->max_image_side || h > ctx->max_image_side) {
    if (err)
      *err += label + ": " + num(w) + " x " + num(h) + " pixels, more than the renderer's texture limit of " +
              num(ctx->max_image_side) + " per side\n";
    return false;
  }
  std::string problem;
  if (bytes[0] == 0x89 && !png_chunks_intact(bytes, size, &problem)) {
    if (err) *err += label + ": " + problem + "\n";
    return false;
  }
  return tinygltf::LoadImageData(image, index, err, warn, req_width, req_height, bytes, size, nullptr);
}

// ---- external URIs (RFC 3986) ----

// RFC 3986 percent-decoding (section 2.1) of a relative reference: "%" HEXDIG HEXDIG is that
// byte, every other character stands for itself, '+' included (a space for '+' is HTML form
// encoding, not URI syntax). Sets *problem for a malformed escape or an escaped NUL, which no
// file name holds.
std::string percent_decode(const std::string& uri, std::string* problem) {
  std::string out;
  for (std::size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] != '%') {
      out += uri[i];
      continue;
    }
    if (i + 2 >= uri.size() || !std::isxdigit(static_cast<unsigned char>(uri[i + 1])) ||
        !std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      *problem =
          "'%' at character " + num(i) + " is not followed by two hex digits (RFC 3986 percent-encoding)";
      return {};
    }
    const char byte = char(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
    if (byte == '\0') {
      *problem = "%00 (a NUL byte) cannot be part of a file name";
      return {};
    }
    out += byte;
    i += 2;
  }
  return out;
}

// Whether any JSON string in the text holds '+', '%' or a backslash-u escape (which could spell
// either): only then can a URI need resolve_uris' rewrite, so other files are not parsed twice.
bool strings_hold_uri_escapes(const unsigned char* p, std::size_t n) {
  bool in_string = false;
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char c = p[i];
    if (!in_string) {
      in_string = c == '"';
    } else if (c == '\\') {
      if (i + 1 < n && p[i + 1] == 'u') return true;
      ++i;
    } else if (c == '"') {
      in_string = false;
    } else if (c == '+' || c == '%') {
      return true;
    }
  }
  return false;
}

void put_le32(std::vector<unsigned char>& out, std::size_t at, std::uint32_t v) {
  for (int b = 0; b < 4; ++b) out[at + std::size_t(b)] = static_cast<unsigned char>(v >> (8 * b));
}

// Debian 12's tinygltf (2.7) opens every external buffer and image through dlib::urldecode,
// which decodes '+' as a space ("a_1e+30.bin" -> "File not found : a_1e 30.bin") and a
// malformed escape as garbage bytes, and has no URI callback. So the file's URIs are resolved
// here first: each buffer and image URI that is not a data: URI is percent-decoded (RFC 3986;
// a malformed one is an error naming the field), and one holding '+' is written back escaped
// for urldecode ('%' -> %25, '+' -> %2B), which then yields exactly the decoded name. The
// bytes come back unchanged when no URI needs that (then tinygltf parses the file as given).
std::vector<unsigned char> resolve_uris(std::vector<unsigned char> bytes, bool binary) {
  std::size_t json_at = 0, json_size = bytes.size();
  if (binary) {
    if (bytes.size() < 20) return bytes;  // tinygltf reports the broken header
    json_at = 20;
    json_size = le32(bytes.data() + 12);
    if (json_size > bytes.size() - 20) return bytes;
  }
  const unsigned char* json = bytes.data() + json_at;
  if (!strings_hold_uri_escapes(json, json_size)) return bytes;
  nlohmann::ordered_json doc = nlohmann::ordered_json::parse(json, json + json_size, nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) return bytes;  // tinygltf reports the JSON error
  bool changed = false;
  for (const char* list : {"buffers", "images"}) {
    if (!doc.contains(list) || !doc[list].is_array()) continue;
    for (std::size_t i = 0; i < doc[list].size(); ++i) {
      nlohmann::ordered_json& item = doc[list][i];
      if (!item.is_object() || !item.contains("uri") || !item["uri"].is_string()) continue;
      const std::string uri = item["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) continue;
      std::string problem;
      const std::string name = percent_decode(uri, &problem);
      if (!problem.empty())
        fail(ErrorCode::format_error,
             std::string(list) + "[" + num(i) + "].uri " + quote(uri) + ": " + problem);
      if (uri.find('+') == std::string::npos) continue;  // urldecode gives the same name
      std::string escaped;
      for (const char c : name) escaped += c == '%' ? "%25" : c == '+' ? "%2B" : std::string(1, c);
      item["uri"] = escaped;
      changed = true;
    }
  }
  if (!changed) return bytes;
  std::string text = doc.dump();
  if (!binary) return std::vector<unsigned char>(text.begin(), text.end());
  // glb: the new JSON chunk (padded with spaces to 4 bytes), then the chunks that followed.
  while (text.size() % 4 != 0) text += ' ';
  const std::size_t rest_at = 20 + json_size, rest = bytes.size() - rest_at;
  if (text.size() + rest > std::numeric_limits<std::uint32_t>::max() - 20)
    fail(ErrorCode::resource_limit, "the glb file would exceed 4 GiB with its URIs re-escaped");
  std::vector<unsigned char> out(20 + text.size() + rest);
  std::memcpy(out.data(), bytes.data(), 12);
  put_le32(out, 8, std::uint32_t(out.size()));
  put_le32(out, 12, std::uint32_t(text.size()));
  std::memcpy(out.data() + 16, "JSON", 4);
  std::memcpy(out.data() + 20, text.data(), text.size());
  std::memcpy(out.data() + 20 + text.size(), bytes.data() + rest_at, rest);
  return out;
}

// ---- JSON text from tinygltf values (the extras become level JSON) ----

void append_json_string(std::string& out, const std::string& s) {
  out += '"';
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", unsigned(static_cast<unsigned char>(c)));
      out += buf;
    } else {
      out += c;
    }
  }
  out += '"';
}

void append_json(std::string& out, const tinygltf::Value& v) {
  if (v.IsBool()) {
    out += v.Get<bool>() ? "true" : "false";
  } else if (v.IsInt()) {
    out += std::to_string(v.Get<int>());
  } else if (v.IsReal()) {
    out += fmt_double(v.Get<double>());
  } else if (v.IsString()) {
    append_json_string(out, v.Get<std::string>());
  } else if (v.IsArray()) {
    out += '[';
    for (std::size_t i = 0; i < v.ArrayLen(); ++i) {
      if (i) out += ',';
      append_json(out, v.Get(int(i)));
    }
    out += ']';
  } else if (v.IsObject()) {
    out += '{';
    bool first = true;
    for (const std::string& key : v.Keys()) {
      if (!first) out += ',';
      first = false;
      append_json_string(out, key);
      out += ':';
      append_json(out, v.Get(key));
    }
    out += '}';
  } else {
    out += "null";
  }
}

std::string json_vec3(const glm::dvec3& v) {
  return "[" + fmt_double(v.x) + "," + fmt_double(v.y) + "," + fmt_double(v.z) + "]";
}

// ---- the loader ----

struct NodeInstance {
  int node = 0;
  glm::dmat4 world{1.0};
  glm::dmat4 parent{1.0};  // the parent's world matrix (identity for a root)
};

struct BlockNode {
  int node = 0;
  glm::dmat4 world{1.0};
  const tinygltf::Value* block = nullptr;  // extras.modrt_block (an object, or true)
};

// A node marked extras.modrt_clutter, collected while its primitives are read; it becomes a
// ClutterObject once the level (and so the default block) is known.
struct ClutterNode {
  int node = 0;
  std::string label;
  ClutterMesh mesh;  // all primitives merged, world space, TEXCOORD_1 as lightmap UVs
  std::optional<int> block;
  int res = precompute::kClutterMeshDefaultRes;
  std::optional<glm::dvec3> albedo;
  int material = -1;  // the first primitive's, for the default albedo
};

class Loader {
 public:
  Loader(const tinygltf::Model& model, const GltfSceneOptions& options, std::string tinygltf_warn)
      : model_(model), options_(options), tinygltf_warn_(std::move(tinygltf_warn)) {}

  DemoScene load(const std::string& path);
  std::vector<std::string>& warnings() { return warnings_; }

 private:
  std::vector<NodeInstance> traverse(const std::vector<int>& roots) const;
  glm::dmat4 local_matrix(int index) const;
  void convert_materials();
  int image_for_texture(int texture, const std::string& what);
  int default_material();
  int material_without_normal_map(int material);
  void add_mesh(int node, const glm::dmat4& transform, bool dynamic, int clutter = -1);
  void read_clutter_extras(const tinygltf::Value& value, ClutterNode& out) const;
  void make_clutter_objects();
  struct Stream {
    const unsigned char* data = nullptr;  // nullptr: an accessor without buffer view (zeros)
    std::size_t stride = 0, count = 0;
    int components = 0, component_type = 0;
    bool normalized = false;
  };
  Stream accessor_stream(int index, const std::string& what, std::size_t cap) const;
  std::vector<float> read_floats(int index, const std::string& what, int components) const;
  std::vector<std::uint32_t> read_indices(int index, const std::string& what) const;
  std::size_t max_indices() const {  // per index accessor: 3 x max_vertices
    return options_.max_vertices > std::numeric_limits<std::size_t>::max() / 3
               ? std::numeric_limits<std::size_t>::max()
               : 3 * options_.max_vertices;
  }
  void add_light(const NodeInstance& inst, int light);
  void read_animations(const std::vector<NodeInstance>& instances);
  KeyTrack read_track(const tinygltf::Animation& animation, int sampler, const std::string& what,
                      const glm::dmat4& parent, std::vector<glm::dvec3>& world_keys) const;
  double animation_duration(const tinygltf::Animation& animation, const std::string& what) const;
  void check_light_positions() const;
  void keep_light_limit();
  void add_default_light();
  std::size_t mesh_corners(int mesh) const;
  void check_vertex_buffer_estimate(const std::vector<NodeInstance>& instances) const;
  void set_camera(const NodeInstance& inst);
  LevelDescription level_from_extras(const std::string& path, const std::vector<BlockNode>& blocks) const;
  const tinygltf::Value* scene_level_extras() const;

  static std::string node_label(const tinygltf::Node& n, int index) {
    return "node " + num(index) + (n.name.empty() ? std::string() : " (" + quote(n.name) + ")");
  }

  const tinygltf::Model& model_;
  const GltfSceneOptions& options_;
  std::string tinygltf_warn_;
  std::vector<std::string> warnings_;
  DemoScene scene_;
  int scene_index_ = -1;
  std::map<int, int> image_of_gltf_image_;
  int default_material_ = -1;
  std::map<int, int> material_without_normal_map_;
  std::size_t total_vertices_ = 0;
  bool have_camera_ = false;
  bool have_dynamic_key_ = false;
  glm::dvec3 dynamic_key_{0.0};
  int dynamic_key_node_ = -1;
  bool warned_morph_ = false, warned_texcoord_ = false, warned_attribute_gap_ = false;
  std::vector<ClutterNode> clutter_nodes_;
  // Per scene_.lights entry: what it is (node and light) and its position in double, for the
  // check against the level's extent once the level is known.
  struct LightSource {
    std::string what;
    glm::dvec3 position{0.0};
    int node = -1;                 // the glTF node carrying it; -1 for a level file's light
    std::vector<glm::dvec3> keys;  // its animation's key positions (world), checked as `position`
    bool directional = false;      // where it stands does not matter
  };
  std::vector<LightSource> light_sources_;
};

// A boolean in `extras`: JSON true or false, or the integers 1 and 0, which Blender's glTF
// exporter writes for boolean custom properties (only exactly 0 and 1; 2 or 0.5 are no booleans).
// nullopt for anything else.
std::optional<bool> extras_bool(const tinygltf::Value& v) {
  if (v.IsBool()) return v.Get<bool>();
  if (v.IsInt() && (v.Get<int>() == 0 || v.Get<int>() == 1)) return v.Get<int>() == 1;
  return std::nullopt;
}

// What extras_bool accepts, for the error messages.
constexpr const char* kExtrasBool = "true or false (or 1 or 0)";

// A node marked as a proxy block that is not drawn (extras.modrt_block true, or an object
// without "draw": true); malformed marks count as drawn here and are reported by load().
bool undrawn_block(const tinygltf::Node& node) {
  if (!node.extras.IsObject() || !node.extras.Has("modrt_block")) return false;
  const tinygltf::Value& b = node.extras.Get("modrt_block");
  if (const std::optional<bool> flag = extras_bool(b)) return *flag;
  if (!b.IsObject()) return false;
  return !(b.Has("draw") && extras_bool(b.Get("draw")).value_or(false));
}

std::size_t saturating_add(std::size_t a, std::size_t b) {
  return b > std::numeric_limits<std::size_t>::max() - a ? std::numeric_limits<std::size_t>::max() : a + b;
}

// Triangle corners one instance of `mesh` draws, from the accessor counts (validated, not
// read): the renderer's vertex buffer holds a vertex per corner (proxy_mapping.h).
std::size_t Loader::mesh_corners(int mesh) const {
  const tinygltf::Mesh& gm = model_.meshes[std::size_t(mesh)];
  std::size_t corners = 0;
  for (std::size_t pi = 0; pi < gm.primitives.size(); ++pi) {
    const tinygltf::Primitive& prim = gm.primitives[pi];
    const std::string what = "mesh " + num(mesh) +
                             (gm.name.empty() ? std::string() : " (" + quote(gm.name) + ")") + " primitive " +
                             num(pi);
    std::size_t count = 0;
    if (prim.indices >= 0) {
      count = accessor_stream(prim.indices, what + " indices", max_indices()).count;
    } else if (const auto it = prim.attributes.find("POSITION"); it != prim.attributes.end()) {
      count = accessor_stream(it->second, what + " POSITION", options_.max_vertices).count;
    }
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode == TINYGLTF_MODE_TRIANGLE_STRIP || mode == TINYGLTF_MODE_TRIANGLE_FAN)
      count = count > 2 ? 3 * (count - 2) : 0;
    else if (mode != TINYGLTF_MODE_TRIANGLES)
      count = 0;  // refused by add_mesh
    // A double-sided static mesh is drawn twice, its back side mapped on its own (the renderer's
    // map_back_sides); counted twice whether the node is static or not.
    if (prim.material >= 0 && std::size_t(prim.material) < model_.materials.size() &&
        model_.materials[std::size_t(prim.material)].doubleSided)
      count = saturating_add(count, count);
    corners = saturating_add(corners, count);
  }
  return corners;
}

// The renderer's vertex buffer for the whole scene, every instance counted, before any mesh
// is expanded: a million nodes sharing a 36-corner cube need 2.9 GB (issue 18).
void Loader::check_vertex_buffer_estimate(const std::vector<NodeInstance>& instances) const {
  std::vector<std::size_t> corners_of_mesh(model_.meshes.size(), std::numeric_limits<std::size_t>::max());
  std::size_t corners = kLightMarkerCorners, drawn = 0;
  for (const NodeInstance& inst : instances) {
    const tinygltf::Node& node = model_.nodes[std::size_t(inst.node)];
    if (node.mesh < 0 || std::size_t(node.mesh) >= model_.meshes.size() || undrawn_block(node)) continue;
    std::size_t& c = corners_of_mesh[std::size_t(node.mesh)];
    if (c == std::numeric_limits<std::size_t>::max()) c = mesh_corners(node.mesh);
    corners = saturating_add(corners, c);
    ++drawn;
  }
  std::size_t meshes = 0;
  for (const std::size_t c : corners_of_mesh) meshes += c != std::numeric_limits<std::size_t>::max();
  if (const std::string problem = vertex_buffer_problem(corners, options_.max_vertex_buffer_bytes);
      !problem.empty())
    fail(ErrorCode::resource_limit, num(drawn) + " drawn node instances of " + num(meshes) +
                                        " meshes (estimated before expanding them): " + problem);
}

std::vector<NodeInstance> Loader::traverse(const std::vector<int>& roots) const {
  std::vector<NodeInstance> out;
  std::vector<char> seen(model_.nodes.size(), 0);
  std::vector<NodeInstance> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, glm::dmat4(1.0)});
  while (!stack.empty()) {
    NodeInstance inst = stack.back();
    stack.pop_back();
    if (inst.node < 0 || std::size_t(inst.node) >= model_.nodes.size())
      fail(ErrorCode::format_error, "node " + num(inst.node) + " is referenced but the file has " +
                                        num(model_.nodes.size()) + " nodes");
    // glTF nodes form a forest; a node reached twice is a cycle or a shared child.
    if (seen[std::size_t(inst.node)])
      fail(ErrorCode::format_error, node_label(model_.nodes[std::size_t(inst.node)], inst.node) +
                                        " is reached twice (a cycle or a node with two parents)");
    seen[std::size_t(inst.node)] = 1;
    inst.parent = inst.world;
    inst.world = inst.world * local_matrix(inst.node);
    out.push_back(inst);
    const std::vector<int>& children = model_.nodes[std::size_t(inst.node)].children;
    for (auto it = children.rbegin(); it != children.rend(); ++it) stack.push_back({*it, inst.world});
  }
  return out;
}

glm::dmat4 Loader::local_matrix(int index) const {
  const tinygltf::Node& n = model_.nodes[std::size_t(index)];
  auto check = [&](const std::vector<double>& v, std::size_t want, const char* what) {
    if (!v.empty() && v.size() != want)
      fail(ErrorCode::format_error,
           node_label(n, index) + ": " + what + " has " + num(v.size()) + " numbers, expected " + num(want));
    for (double x : v)
      if (!std::isfinite(x))
        fail(ErrorCode::format_error, node_label(n, index) + ": " + what + " is not finite");
  };
  check(n.matrix, 16, "matrix");
  check(n.translation, 3, "translation");
  check(n.rotation, 4, "rotation");
  check(n.scale, 3, "scale");
  if (!n.matrix.empty()) {
    glm::dmat4 m(1.0);
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) m[c][r] = n.matrix[std::size_t(4 * c + r)];  // glTF is column-major
    return m;
  }
  glm::dmat4 m(1.0);
  if (!n.translation.empty()) m[3] = glm::dvec4(n.translation[0], n.translation[1], n.translation[2], 1.0);
  if (!n.rotation.empty()) {
    glm::dquat q(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]);  // glTF stores x, y, z, w
    const double len = glm::length(q);
    if (!(len > 1e-12)) fail(ErrorCode::format_error, node_label(n, index) + ": rotation quaternion is zero");
    m = m * glm::dmat4(glm::mat4_cast(q / len));
  }
  if (!n.scale.empty()) {
    glm::dmat4 s(1.0);
    s[0][0] = n.scale[0], s[1][1] = n.scale[1], s[2][2] = n.scale[2];
    m = m * s;
  }
  return m;
}

Loader::Stream Loader::accessor_stream(int index, const std::string& what, std::size_t cap) const {
  if (index < 0 || std::size_t(index) >= model_.accessors.size())
    fail(ErrorCode::format_error, what + " refers to accessor " + num(index) + "; the file has " +
                                      num(model_.accessors.size()) + " accessors");
  const tinygltf::Accessor& a = model_.accessors[std::size_t(index)];
  const std::string name = "accessor " + num(index) + " (" + what + ")";
  if (a.sparse.isSparse) fail(ErrorCode::format_error, name + ": sparse accessors are not supported");
  const int components = tinygltf::GetNumComponentsInType(std::uint32_t(a.type));
  const int component_size = tinygltf::GetComponentSizeInBytes(std::uint32_t(a.componentType));
  if (components <= 0 || component_size <= 0 || a.componentType == TINYGLTF_COMPONENT_TYPE_DOUBLE)
    fail(ErrorCode::format_error,
         name + ": invalid type " + num(a.type) + " or componentType " + num(a.componentType));
  if (a.count > cap)
    fail(ErrorCode::resource_limit,
         name + ": " + num(a.count) + " elements, more than the limit of " + num(cap));
  Stream s;
  s.count = a.count;
  s.components = components;
  s.component_type = a.componentType;
  s.normalized = a.normalized;
  const std::size_t element = std::size_t(components) * std::size_t(component_size);
  s.stride = element;
  // Without a buffer view glTF means all zeros (a base for sparse accessors, which are not
  // supported): refused, so that a few bytes of JSON cannot demand gigabytes of zeros.
  if (a.bufferView < 0)
    fail(ErrorCode::format_error, name + ": no bufferView (all zeros; sparse accessors are not supported)");
  if (a.count == 0) return s;
  if (std::size_t(a.bufferView) >= model_.bufferViews.size())
    fail(ErrorCode::format_error, name + ": buffer view " + num(a.bufferView) +
                                      " does not exist; the file has " + num(model_.bufferViews.size()));
  const tinygltf::BufferView& view = model_.bufferViews[std::size_t(a.bufferView)];
  if (view.buffer < 0 || std::size_t(view.buffer) >= model_.buffers.size())
    fail(ErrorCode::format_error, name + ": buffer view " + num(a.bufferView) + " refers to buffer " +
                                      num(view.buffer) + "; the file has " + num(model_.buffers.size()));
  const std::vector<unsigned char>& buffer = model_.buffers[std::size_t(view.buffer)].data;
  if (view.byteOffset > buffer.size() || view.byteLength > buffer.size() - view.byteOffset)
    fail(ErrorCode::format_error, name + ": buffer view " + num(a.bufferView) + " (offset " +
                                      num(view.byteOffset) + ", " + num(view.byteLength) +
                                      " bytes) lies outside buffer " + num(view.buffer) + " (" +
                                      num(buffer.size()) + " bytes)");
  if (view.byteStride != 0) {
    if (view.byteStride < element)
      fail(ErrorCode::format_error, name + ": byteStride " + num(view.byteStride) + " of buffer view " +
                                        num(a.bufferView) + " is less than the element size " + num(element));
    s.stride = view.byteStride;
  }
  {
    // count <= cap and stride <= byteLength keep this product far from overflowing.
    const bool fits = a.byteOffset <= view.byteLength && s.stride <= view.byteLength &&
                      (s.count - 1) * s.stride + element <= view.byteLength - a.byteOffset;
    if (!fits)
      fail(ErrorCode::format_error, name + ": accessor out of range: " + num(s.count) + " elements of " +
                                        num(element) + " bytes (stride " + num(s.stride) + ", offset " +
                                        num(a.byteOffset) + ") do not fit in buffer view " +
                                        num(a.bufferView) + " of " + num(view.byteLength) + " bytes");
  }
  s.data = buffer.data() + view.byteOffset + a.byteOffset;
  return s;
}

std::vector<float> Loader::read_floats(int index, const std::string& what, int components) const {
  const Stream s = accessor_stream(index, what, options_.max_vertices);
  if (s.components != components)
    fail(ErrorCode::format_error, "accessor " + num(index) + " (" + what + ") has " + num(s.components) +
                                      " components per element, expected " + num(components));
  std::vector<float> out(s.count * std::size_t(components), 0.0f);
  if (!s.data) return out;
  const int ct = s.component_type;
  for (std::size_t i = 0; i < s.count; ++i) {
    const unsigned char* e = s.data + i * s.stride;
    for (int c = 0; c < components; ++c) {
      double v = 0.0;
      switch (ct) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT: {
          float f;
          std::memcpy(&f, e + 4 * c, 4);
          v = f;
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
          const auto x = static_cast<std::int8_t>(e[c]);
          v = s.normalized ? std::max(double(x) / 127.0, -1.0) : double(x);
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: v = s.normalized ? e[c] / 255.0 : double(e[c]); break;
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
          std::int16_t x;
          std::memcpy(&x, e + 2 * c, 2);
          v = s.normalized ? std::max(double(x) / 32767.0, -1.0) : double(x);
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
          std::uint16_t x;
          std::memcpy(&x, e + 2 * c, 2);
          v = s.normalized ? x / 65535.0 : double(x);
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_INT: {
          std::int32_t x;
          std::memcpy(&x, e + 4 * c, 4);
          v = double(x);
          break;
        }
        default: {
          std::uint32_t x;
          std::memcpy(&x, e + 4 * c, 4);
          v = double(x);
          break;
        }
      }
      if (!std::isfinite(v))
        fail(ErrorCode::non_finite,
             "accessor " + num(index) + " (" + what + "): element " + num(i) + " is not finite");
      out[i * std::size_t(components) + std::size_t(c)] = float(v);
    }
  }
  return out;
}

std::vector<std::uint32_t> Loader::read_indices(int index, const std::string& what) const {
  const Stream s = accessor_stream(index, what, max_indices());
  const int ct = s.component_type;
  if (s.components != 1 ||
      (ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
       ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT))
    fail(ErrorCode::format_error,
         "accessor " + num(index) + " (" + what + "): indices must be unsigned byte, short or int scalars");
  std::vector<std::uint32_t> out(s.count, 0);
  if (!s.data) return out;
  for (std::size_t i = 0; i < s.count; ++i) {
    const unsigned char* e = s.data + i * s.stride;
    if (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
      out[i] = e[0];
    } else if (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
      std::uint16_t x;
      std::memcpy(&x, e, 2);
      out[i] = x;
    } else {
      std::memcpy(&out[i], e, 4);
    }
  }
  return out;
}

int Loader::image_for_texture(int texture, const std::string& what) {
  if (texture < 0 || std::size_t(texture) >= model_.textures.size())
    fail(ErrorCode::format_error, what + " refers to texture " + num(texture) + "; the file has " +
                                      num(model_.textures.size()) + " textures");
  const tinygltf::Texture& tex = model_.textures[std::size_t(texture)];
  if (tex.source < 0) {
    std::string ext;
    for (const auto& [name, value] : tex.extensions) ext += (ext.empty() ? "" : ", ") + name;
    fail(ErrorCode::format_error,
         what + ": texture " + num(texture) + " has no PNG or JPEG source" +
             (ext.empty() ? std::string() : " (only an extension's image: " + ext + ")") +
             "; unsupported image format");
  }
  if (std::size_t(tex.source) >= model_.images.size())
    fail(ErrorCode::format_error, what + ": texture " + num(texture) + " refers to image " + num(tex.source) +
                                      "; the file has " + num(model_.images.size()) + " images");
  if (auto it = image_of_gltf_image_.find(tex.source); it != image_of_gltf_image_.end()) return it->second;
  const tinygltf::Image& img = model_.images[std::size_t(tex.source)];
  std::string label = "image " + num(tex.source);
  if (!img.uri.empty())
    label += " (" + img.uri + ")";
  else if (!img.name.empty())
    label += " (" + quote(img.name) + ")";
  if (img.image.empty())
    fail(ErrorCode::io_error,
         label + " could not be loaded (missing image file?)" +
             (tinygltf_warn_.empty() ? std::string() : ": " + join_lines(tinygltf_warn_)));
  const int comp = img.component, bytes = img.bits / 8;
  if (img.width < 1 || img.height < 1 || comp < 1 || comp > 4 || (bytes != 1 && bytes != 2) ||
      img.image.size() != std::size_t(img.width) * std::size_t(img.height) * std::size_t(comp * bytes))
    fail(ErrorCode::format_error, label + ": decoded as " + num(img.width) + " x " + num(img.height) + ", " +
                                      num(comp) + " channels of " + num(img.bits) +
                                      " bits, which the renderer cannot use (RGBA8 needed)");
  Image out;
  out.name = img.name.empty() ? (img.uri.empty() ? label : img.uri) : img.name;
  out.width = img.width;
  out.height = img.height;
  const std::size_t pixels = std::size_t(img.width) * std::size_t(img.height);
  out.rgba.resize(4 * pixels);
  // 16-bit channels keep their high byte; grey expands to RGB; missing alpha is opaque.
  auto channel = [&](std::size_t p, int c) -> std::uint8_t {
    const std::size_t at = (p * std::size_t(comp) + std::size_t(c)) * std::size_t(bytes);
    if (bytes == 1) return img.image[at];
    std::uint16_t v;  // stb's 16-bit samples are native-endian
    std::memcpy(&v, &img.image[at], 2);
    return std::uint8_t(v >> 8);
  };
  for (std::size_t p = 0; p < pixels; ++p) {
    std::uint8_t* o = out.rgba.data() + 4 * p;
    if (comp >= 3) {
      o[0] = channel(p, 0), o[1] = channel(p, 1), o[2] = channel(p, 2);
      o[3] = comp == 4 ? channel(p, 3) : 255;
    } else {
      o[0] = o[1] = o[2] = channel(p, 0);
      o[3] = comp == 2 ? channel(p, 1) : 255;
    }
  }
  scene_.images.push_back(std::move(out));
  const int result = int(scene_.images.size()) - 1;
  image_of_gltf_image_[tex.source] = result;
  return result;
}

void Loader::convert_materials() {
  for (std::size_t i = 0; i < model_.materials.size(); ++i) {
    const tinygltf::Material& gm = model_.materials[i];
    const std::string what =
        "material " + num(i) + (gm.name.empty() ? std::string() : " (" + quote(gm.name) + ")");
    Material m;
    m.name = gm.name.empty() ? "material " + num(i) : gm.name;
    const std::vector<double>& f = gm.pbrMetallicRoughness.baseColorFactor;
    if (f.size() != 4)
      fail(ErrorCode::format_error, what + ": baseColorFactor has " + num(f.size()) + " numbers");
    for (double x : f)
      if (!std::isfinite(x) || x < 0.0)
        fail(ErrorCode::format_error,
             what + ": baseColorFactor " + short_double(x) + " is not a finite number >= 0");
    m.base_color = glm::vec3(float(f[0]), float(f[1]), float(f[2]));  // glTF factors are linear already
    m.double_sided = gm.doubleSided;
    const tinygltf::TextureInfo& base = gm.pbrMetallicRoughness.baseColorTexture;
    if (base.index >= 0) {
      m.base_color_texture = image_for_texture(base.index, what + " baseColorTexture");
      if (base.texCoord != 0 && !warned_texcoord_) {
        warned_texcoord_ = true;
        warnings_.push_back(what + ": baseColorTexture uses TEXCOORD_" + num(base.texCoord) +
                            "; the demo reads TEXCOORD_0 only");
      }
    }
    if (gm.normalTexture.index >= 0) {
      m.normal_texture = image_for_texture(gm.normalTexture.index, what + " normalTexture");
      m.normal_scale = float(gm.normalTexture.scale);
      if (gm.normalTexture.texCoord != 0 && !warned_texcoord_) {
        warned_texcoord_ = true;
        warnings_.push_back(what + ": normalTexture uses TEXCOORD_" + num(gm.normalTexture.texCoord) +
                            "; the demo reads TEXCOORD_0 only");
      }
    }
    scene_.materials.push_back(std::move(m));
  }
}

int Loader::default_material() {
  if (default_material_ < 0) {
    Material m;
    m.name = "glTF default";
    // The glTF default base colour is white; an albedo of 1 would never lose energy
    // between bounces, so primitives without a material get the demo's neutral grey.
    m.base_color = Material{}.base_color;
    scene_.materials.push_back(m);
    default_material_ = int(scene_.materials.size()) - 1;
  }
  return default_material_;
}

int Loader::material_without_normal_map(int material) {
  if (auto it = material_without_normal_map_.find(material); it != material_without_normal_map_.end())
    return it->second;
  Material m = scene_.materials[std::size_t(material)];
  m.normal_texture = -1;
  m.name += " (no normal map)";
  scene_.materials.push_back(m);
  const int index = int(scene_.materials.size()) - 1;
  material_without_normal_map_[material] = index;
  return index;
}

glm::vec3 any_perpendicular(const glm::vec3& n) {
  const glm::vec3 axis = std::abs(n.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  return glm::normalize(glm::cross(axis, n));
}

void Loader::add_mesh(int node_index, const glm::dmat4& transform, bool dynamic, int clutter) {
  const tinygltf::Node& node = model_.nodes[std::size_t(node_index)];
  if (node.mesh < 0 || std::size_t(node.mesh) >= model_.meshes.size())
    fail(ErrorCode::format_error, node_label(node, node_index) + " refers to mesh " + num(node.mesh) +
                                      "; the file has " + num(model_.meshes.size()) + " meshes");
  const tinygltf::Mesh& gm = model_.meshes[std::size_t(node.mesh)];
  const glm::dmat3 linear(transform);
  const double det = glm::determinant(linear);
  if (!std::isfinite(det) || std::abs(det) < 1e-30) {
    warnings_.push_back(node_label(node, node_index) + ": its transform is singular; its mesh is skipped");
    return;
  }
  const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(linear));
  const bool mirrored = det < 0.0;
  for (std::size_t pi = 0; pi < gm.primitives.size(); ++pi) {
    const tinygltf::Primitive& prim = gm.primitives[pi];
    const std::string what = "mesh " + num(node.mesh) +
                             (gm.name.empty() ? std::string() : " (" + quote(gm.name) + ")") + " primitive " +
                             num(pi);
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        mode != TINYGLTF_MODE_TRIANGLE_FAN)
      fail(ErrorCode::format_error,
           what + ": primitive mode " + num(mode) + " (" + mode_name(mode) +
               ") is not supported; only triangles (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN)");
    if (!prim.targets.empty() && !warned_morph_) {
      warned_morph_ = true;
      warnings_.push_back(what + ": morph targets are ignored (drawn with the base geometry)");
    }
    auto attribute = [&](const char* name) {
      const auto it = prim.attributes.find(name);
      return it == prim.attributes.end() ? -1 : it->second;
    };
    const int pos_acc = attribute("POSITION");
    if (pos_acc < 0) fail(ErrorCode::format_error, what + ": missing POSITION attribute");
    const std::vector<float> pos = read_floats(pos_acc, what + " POSITION", 3);
    const std::size_t n = pos.size() / 3;
    auto read_attribute = [&](const char* name, int components) {
      const int acc = attribute(name);
      if (acc < 0) return std::vector<float>();
      std::vector<float> v = read_floats(acc, what + " " + name, components);
      if (v.size() / std::size_t(components) != n)
        fail(ErrorCode::format_error, what + ": " + name + " has " + num(v.size() / std::size_t(components)) +
                                          " elements, POSITION has " + num(n));
      return v;
    };
    // glTF numbers attribute sets from 0 without gaps; the Khronos validator refuses TEXCOORD_1
    // without TEXCOORD_0 (clutter_room.gltf had that), other tools may drop the set.
    for (const char* set : {"TEXCOORD", "COLOR", "JOINTS", "WEIGHTS"})
      for (int k = 1; k < 8 && !warned_attribute_gap_; ++k)
        if (attribute((std::string(set) + "_" + num(k)).c_str()) >= 0 &&
            attribute((std::string(set) + "_" + num(k - 1)).c_str()) < 0) {
          warned_attribute_gap_ = true;
          warnings_.push_back(what + ": " + set + "_" + num(k) + " without " + set + "_" + num(k - 1) +
                              " (glTF numbers attribute sets from 0 without gaps; the Khronos glTF "
                              "validator refuses the file)");
        }
    std::vector<float> nrm = read_attribute("NORMAL", 3);
    std::vector<float> uv = read_attribute("TEXCOORD_0", 2);
    std::vector<float> lightmap_uv;
    if (clutter >= 0) {
      if (attribute("TEXCOORD_1") < 0)
        fail(ErrorCode::format_error, node_label(node, node_index) + ": " + what +
                                          ": a clutter mesh (extras.modrt_clutter) needs lightmap UVs in "
                                          "TEXCOORD_1; the primitive has none");
      lightmap_uv = read_attribute("TEXCOORD_1", 2);
    }

    std::vector<std::uint32_t> idx;
    if (prim.indices >= 0) {
      idx = read_indices(prim.indices, what + " indices");
      for (std::size_t i = 0; i < idx.size(); ++i)
        if (idx[i] >= n)
          fail(ErrorCode::format_error, what + ": index out of range: index " + num(i) + " is " +
                                            std::to_string(idx[i]) + ", the primitive has " + num(n) +
                                            " vertices");
    } else {
      if (n > std::numeric_limits<std::uint32_t>::max())
        fail(ErrorCode::resource_limit, what + ": more than 2^32 vertices");
      idx.resize(n);
      for (std::size_t i = 0; i < n; ++i) idx[i] = std::uint32_t(i);
    }
    if (mode != TINYGLTF_MODE_TRIANGLES) {
      if (idx.size() > 2 && idx.size() - 2 > options_.max_vertices)
        fail(ErrorCode::resource_limit, what + ": " + num(idx.size() - 2) +
                                            " strip or fan triangles, more than the limit of " +
                                            num(options_.max_vertices));
      std::vector<std::uint32_t> list;
      for (std::size_t i = 2; i < idx.size(); ++i) {
        std::uint32_t a = mode == TINYGLTF_MODE_TRIANGLE_FAN ? idx[0] : idx[i - 2], b = idx[i - 1],
                      c = idx[i];
        if (mode == TINYGLTF_MODE_TRIANGLE_STRIP && i % 2 == 1) std::swap(a, b);  // keep the winding
        list.insert(list.end(), {a, b, c});
      }
      idx = std::move(list);
    } else if (idx.size() % 3 != 0) {
      fail(ErrorCode::format_error,
           what + ": " + num(idx.size()) + " indices is not a multiple of 3 (TRIANGLES)");
    }
    if (idx.empty()) continue;
    if (mirrored)
      for (std::size_t t = 0; t + 2 < idx.size(); t += 3) std::swap(idx[t + 1], idx[t + 2]);
    if (clutter >= 0) {
      // The primitives of a clutter node form one mesh (one lightmap atlas), in world space.
      ClutterMesh& cm = clutter_nodes_[std::size_t(clutter)].mesh;
      const std::size_t base = cm.positions.size();
      if (base + n > std::numeric_limits<std::uint32_t>::max())
        fail(ErrorCode::resource_limit, what + ": the clutter mesh has more than 2^32 vertices");
      for (std::size_t v = 0; v < n; ++v) {
        cm.positions.push_back(glm::dvec3(
            transform * glm::dvec4(double(pos[3 * v]), double(pos[3 * v + 1]), double(pos[3 * v + 2]), 1.0)));
        cm.uvs.push_back(glm::dvec2(lightmap_uv[2 * v], lightmap_uv[2 * v + 1]));
      }
      for (std::uint32_t i : idx) cm.indices.push_back(std::uint32_t(base) + i);
    }

    int material = prim.material;
    if (material >= 0 && std::size_t(material) >= model_.materials.size())
      fail(ErrorCode::format_error, what + " refers to material " + num(material) + "; the file has " +
                                        num(model_.materials.size()) + " materials");
    if (material < 0) material = default_material();
    bool normal_mapped = scene_.materials[std::size_t(material)].normal_texture >= 0;
    if (normal_mapped && uv.empty()) {
      warnings_.push_back(what +
                          ": the material has a normal map but the primitive has no TEXCOORD_0; drawn "
                          "without the normal map");
      material = material_without_normal_map(material);
      normal_mapped = false;
    }
    std::vector<float> tan = normal_mapped ? read_attribute("TANGENT", 4) : std::vector<float>();

    // Flat normals (the glTF rule for primitives without NORMAL) need a vertex per corner.
    const bool split = nrm.empty() && !options_.smooth_missing_normals;
    const std::size_t out_vertices = split ? idx.size() : n;
    if (out_vertices > options_.max_vertices - std::min(total_vertices_, options_.max_vertices))
      fail(ErrorCode::resource_limit,
           what + ": the scene would have more than " + num(options_.max_vertices) + " vertices");
    total_vertices_ += out_vertices;

    Mesh mesh;
    mesh.name = (node.name.empty() ? "node " + num(node_index) : node.name) +
                (gm.primitives.size() > 1 ? " #" + num(pi) : std::string());
    mesh.material = material;
    mesh.dynamic = dynamic;
    if (clutter >= 0) {
      mesh.clutter = clutter;
      if (clutter_nodes_[std::size_t(clutter)].material < 0)
        clutter_nodes_[std::size_t(clutter)].material = material;
    }
    auto local_pos = [&](std::size_t v) { return glm::dvec3(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]); };
    const std::vector<std::uint32_t>& src = idx;  // corner -> source vertex
    auto source = [&](std::size_t out_v) { return split ? src[out_v] : std::uint32_t(out_v); };
    mesh.position.resize(out_vertices);
    mesh.normal.resize(out_vertices);
    if (!uv.empty()) mesh.uv.resize(out_vertices);
    if (!lightmap_uv.empty()) mesh.lightmap_uv.resize(out_vertices);
    for (std::size_t v = 0; v < out_vertices; ++v) {
      const std::uint32_t s = source(v);
      mesh.position[v] = glm::vec3(transform * glm::dvec4(local_pos(s), 1.0));
      if (!uv.empty()) mesh.uv[v] = glm::vec2(uv[2 * s], uv[2 * s + 1]);
      if (!lightmap_uv.empty()) mesh.lightmap_uv[v] = glm::vec2(lightmap_uv[2 * s], lightmap_uv[2 * s + 1]);
      if (!nrm.empty()) {
        const glm::dvec3 nn = normal_matrix * glm::dvec3(nrm[3 * s], nrm[3 * s + 1], nrm[3 * s + 2]);
        const double len = glm::length(nn);
        mesh.normal[v] = len > 0.0 ? glm::vec3(nn / len) : glm::vec3(0.0f, 1.0f, 0.0f);
      }
    }
    if (split) {
      mesh.indices.resize(out_vertices);
      for (std::size_t v = 0; v < out_vertices; ++v) mesh.indices[v] = std::uint32_t(v);
    } else {
      mesh.indices = idx;
    }
    if (nrm.empty()) {
      // World-space face normals (the index order is already corrected for mirroring):
      // per corner when split, area-weighted sums per shared vertex otherwise.
      std::vector<glm::dvec3> acc(out_vertices, glm::dvec3(0.0));
      for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        const std::uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
        const glm::dvec3 fn = glm::cross(glm::dvec3(mesh.position[b] - mesh.position[a]),
                                         glm::dvec3(mesh.position[c] - mesh.position[a]));
        acc[a] += fn, acc[b] += fn, acc[c] += fn;
      }
      for (std::size_t v = 0; v < out_vertices; ++v) {
        const double len = glm::length(acc[v]);
        mesh.normal[v] = len > 0.0 ? glm::vec3(acc[v] / len) : glm::vec3(0.0f, 1.0f, 0.0f);
      }
    }
    if (normal_mapped) {
      mesh.tangent.resize(out_vertices);
      if (!tan.empty()) {
        for (std::size_t v = 0; v < out_vertices; ++v) {
          const std::uint32_t s = source(v);
          const glm::dvec3 t = linear * glm::dvec3(tan[4 * s], tan[4 * s + 1], tan[4 * s + 2]);
          const double len = glm::length(t);
          // A mirroring transform flips the bitangent cross(n, t) relative to the turned one.
          const float w = (tan[4 * s + 3] < 0.0f ? -1.0f : 1.0f) * (mirrored ? -1.0f : 1.0f);
          mesh.tangent[v] = glm::vec4(len > 0.0 ? glm::vec3(t / len) : any_perpendicular(mesh.normal[v]), w);
        }
      } else {
        // Tangents from the UV gradients (Lengyel), in world space. glTF's v runs down the
        // image while the normal map's green points up it, so the bitangent cross(n, t) * w
        // must point along -dP/dv.
        std::vector<glm::dvec3> dpdu(out_vertices, glm::dvec3(0.0)), dpdv(out_vertices, glm::dvec3(0.0));
        for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
          const std::uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
          const glm::dvec3 e1(mesh.position[b] - mesh.position[a]), e2(mesh.position[c] - mesh.position[a]);
          const glm::dvec2 d1(mesh.uv[b] - mesh.uv[a]), d2(mesh.uv[c] - mesh.uv[a]);
          const double r = d1.x * d2.y - d2.x * d1.y;
          if (std::abs(r) < 1e-20) continue;
          const glm::dvec3 su = (e1 * d2.y - e2 * d1.y) / r, sv = (e2 * d1.x - e1 * d2.x) / r;
          for (std::uint32_t v : {a, b, c}) dpdu[v] += su, dpdv[v] += sv;
        }
        for (std::size_t v = 0; v < out_vertices; ++v) {
          const glm::dvec3 nv(mesh.normal[v]);
          glm::dvec3 t = dpdu[v] - nv * glm::dot(nv, dpdu[v]);
          const double len = glm::length(t);
          const glm::vec3 tv = len > 1e-20 ? glm::vec3(t / len) : any_perpendicular(mesh.normal[v]);
          const float w = glm::dot(glm::cross(nv, glm::dvec3(tv)), -dpdv[v]) < 0.0 ? -1.0f : 1.0f;
          mesh.tangent[v] = glm::vec4(tv, w);
        }
      }
    }
    mesh.source_node = node_index;
    mesh.source_primitive = int(pi);
    scene_.meshes.push_back(std::move(mesh));
  }
}

void Loader::read_clutter_extras(const tinygltf::Value& value, ClutterNode& out) const {
  const std::string where = out.label + ": extras.modrt_clutter";
  if (extras_bool(value)) return;  // true (false never gets here): every field at its default
  if (!value.IsObject()) fail(ErrorCode::format_error, where + " must be an object (or true or 1)");
  for (const std::string& key : value.Keys())
    if (key != "block" && key != "res" && key != "albedo")
      fail(ErrorCode::format_error,
           where + ": unknown field " + quote(key) + "; allowed: block, res, albedo");
  auto integer = [&](const char* key) {
    const tinygltf::Value& v = value.Get(key);
    // tinygltf keeps JSON integers as int and other numbers as real.
    if (!v.IsInt()) fail(ErrorCode::format_error, where + "." + key + " must be an integer");
    return v.Get<int>();
  };
  if (value.Has("block")) {
    out.block = integer("block");
    if (*out.block < 0) fail(ErrorCode::format_error, where + ".block " + num(*out.block) + " is negative");
  }
  if (value.Has("res")) {
    out.res = integer("res");
    if (out.res < 1 || out.res > 1024)
      fail(ErrorCode::format_error, where + ".res " + num(out.res) + " is not 1..1024");
  }
  if (value.Has("albedo")) {
    const tinygltf::Value& a = value.Get("albedo");
    if (!a.IsArray() || a.ArrayLen() != 3)
      fail(ErrorCode::format_error, where + ".albedo must be an array of 3 numbers [r, g, b]");
    glm::dvec3 rgb(0.0);
    for (int c = 0; c < 3; ++c) {
      const tinygltf::Value& x = a.Get(c);
      if (!x.IsNumber()) fail(ErrorCode::format_error, where + ".albedo[" + num(c) + "] is not a number");
      rgb[c] = x.GetNumberAsDouble();
      if (!(rgb[c] >= 0.0 && rgb[c] <= 1.0))
        fail(ErrorCode::format_error,
             where + ".albedo[" + num(c) + "] " + short_double(rgb[c]) + " is not in [0, 1]");
    }
    out.albedo = rgb;
  }
}

// The DRT build's inside and entry tests (ClutterMeshShape) count surface crossings, which
// only mean something for a closed, consistently wound surface: every edge, with vertices
// welded by position (UV seams split them), must border exactly two triangles, once in
// each direction.
std::string short_vec3(const glm::dvec3& v) {
  return "(" + short_double(v.x) + ", " + short_double(v.y) + ", " + short_double(v.z) + ")";
}

std::string open_edge(const ClutterMesh& mesh) {
  std::map<std::array<double, 3>, std::uint32_t> weld;
  std::vector<std::uint32_t> id(mesh.positions.size());
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const glm::dvec3& p = mesh.positions[v];
    id[v] = weld.emplace(std::array<double, 3>{p.x, p.y, p.z}, std::uint32_t(weld.size())).first->second;
  }
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = id[mesh.indices[t + std::size_t(k)]],
                          b = id[mesh.indices[t + std::size_t((k + 1) % 3)]];
      if (a != b) ++directed[{a, b}];
    }
  for (const auto& [edge, count] : directed) {
    const auto back = directed.find({edge.second, edge.first});
    const int reverse = back == directed.end() ? 0 : back->second;
    if (count != 1 || reverse != 1) {
      glm::dvec3 pa(0.0), pb(0.0);
      for (std::size_t v = 0; v < id.size(); ++v) {
        if (id[v] == edge.first) pa = mesh.positions[v];
        if (id[v] == edge.second) pb = mesh.positions[v];
      }
      return "the edge " + short_vec3(pa) + " - " + short_vec3(pb) + " borders " + num(count) +
             " triangle(s) in one direction and " + num(reverse) + " in the other";
    }
  }
  return {};
}

void Loader::make_clutter_objects() {
  const LevelDescription& level = scene_.level;
  for (ClutterNode& c : clutter_nodes_) {
    const std::string where = c.label + ": extras.modrt_clutter";
    if (c.mesh.indices.empty()) fail(ErrorCode::format_error, where + ": the node's mesh has no triangles");
    // Before anything orders or averages positions: NaN would break the edge map's ordering.
    for (std::size_t v = 0; v < c.mesh.positions.size(); ++v)
      if (const glm::dvec3& p = c.mesh.positions[v];
          !(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)))
        fail(ErrorCode::format_error, where + ": vertex " + num(v) + " of the merged mesh is not finite");
    glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const glm::dvec3& p : c.mesh.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
    int block = -1;
    if (c.block) {
      if (std::size_t(*c.block) >= level.blocks.size())
        fail(ErrorCode::format_error, where + ".block " + num(*c.block) + " does not exist; the level has " +
                                          num(level.blocks.size()) + " blocks");
      block = *c.block;
    } else {
      const glm::dvec3 centre = 0.5 * (lo + hi);
      const glm::dvec3 cell_f = glm::floor(centre / level.cell_size);
      // A cell far outside int range is no block's (and must not be converted to int).
      if (glm::all(glm::lessThan(glm::abs(cell_f), glm::dvec3(1e9)))) {
        const glm::ivec3 cell(cell_f);
        for (std::size_t b = 0; b < level.blocks.size() && block < 0; ++b)
          if (level.blocks[b].cell == cell) block = int(b);
      }
      if (block < 0)
        fail(ErrorCode::format_error, where +
                                          ": no block given and no block's cell contains the mesh's centre " +
                                          short_vec3(centre) + "; set extras.modrt_clutter.block");
    }
    glm::dvec3 albedo(0.0);
    if (c.albedo) {
      albedo = *c.albedo;
    } else {
      albedo = glm::dvec3(scene_.materials[std::size_t(c.material)].base_color);
      if (!(glm::all(glm::greaterThanEqual(albedo, glm::dvec3(0.0))) &&
            glm::all(glm::lessThanEqual(albedo, glm::dvec3(1.0)))))
        fail(ErrorCode::format_error, where + ": the material's base colour " + short_vec3(albedo) +
                                          " is not an albedo in [0, 1]; give extras.modrt_clutter.albedo");
    }
    if (const std::string open = open_edge(c.mesh); !open.empty())
      fail(ErrorCode::format_error, where + ": the mesh is not closed (" + open +
                                        "); DRT's inside and entry tests need a closed surface");
    Result<ClutterObject> object =
        precompute::make_mesh_clutter(std::move(c.mesh), block, albedo, c.res, c.label);
    if (!object.ok()) fail(object.status().code(), "clutter mesh: " + object.status().message());
    scene_.clutter.push_back(std::move(object).value());
  }
}

void Loader::add_light(const NodeInstance& inst, int light) {
  const tinygltf::Node& node = model_.nodes[std::size_t(inst.node)];
  if (light < 0 || std::size_t(light) >= model_.lights.size())
    fail(ErrorCode::format_error, node_label(node, inst.node) + " refers to light " + num(light) +
                                      "; the file has " + num(model_.lights.size()) +
                                      " KHR_lights_punctual lights");
  const tinygltf::Light& l = model_.lights[std::size_t(light)];
  const std::string what =
      "light " + num(light) + (l.name.empty() ? std::string() : " (" + quote(l.name) + ")");
  if (l.type != "point" && l.type != "spot" && l.type != "directional") {
    warnings_.push_back(what + ": unknown light type " + quote(l.type) + "; skipped");
    return;
  }
  glm::dvec3 color(1.0);
  if (!l.color.empty()) {
    if (l.color.size() != 3)
      fail(ErrorCode::format_error, what + ": color has " + num(l.color.size()) + " numbers, expected 3");
    color = glm::dvec3(l.color[0], l.color[1], l.color[2]);
  }
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(color[c]) || color[c] < 0.0)
      fail(ErrorCode::format_error, what + ": color must be finite and >= 0");
  if (!std::isfinite(l.intensity) || l.intensity < 0.0)
    fail(ErrorCode::format_error,
         what + ": intensity " + short_double(l.intensity) + " must be finite and >= 0");
  DemoLight d;
  const glm::dvec3 position(inst.world[3]);
  if (!(std::isfinite(position.x) && std::isfinite(position.y) && std::isfinite(position.z)))
    fail(ErrorCode::format_error, node_label(node, inst.node) + ": " + what +
                                      ": its world position is not finite (node transforms overflow)");
  d.path = {glm::vec3(position)};
  if (l.type == "directional") {
    // KHR_lights_punctual: along its node's local -Z; intensity in lux (lm/m^2), scaled to
    // irradiance as a point light's candela (lm/sr) to W/sr.
    const glm::dvec3 dir = glm::dmat3(inst.world) * glm::dvec3(0, 0, -1);
    if (!(glm::length(dir) > 1e-12)) fail(ErrorCode::format_error, what + ": its node transform is singular");
    d.direction = glm::vec3(glm::normalize(dir));
    d.directional = true;
  }
  if (l.type == "spot") {
    const double inner = l.spot.innerConeAngle, outer = l.spot.outerConeAngle;
    if (!(inner >= 0.0 && inner < outer && outer <= 0.5 * 3.14159265358979 + 1e-9))
      fail(ErrorCode::format_error, what + ": spot cone angles (inner " + short_double(inner) + ", outer " +
                                        short_double(outer) + ") must satisfy 0 <= inner < outer <= pi/2");
    // KHR_lights_punctual spot lights shine along their node's local -Z.
    const glm::dvec3 dir = glm::dmat3(inst.world) * glm::dvec3(0, 0, -1);
    if (!(glm::length(dir) > 1e-12)) fail(ErrorCode::format_error, what + ": its node transform is singular");
    d.direction = glm::vec3(glm::normalize(dir));
    d.inner_cone = float(inner);
    d.outer_cone = float(outer);
  }
  // In double: a colour or intensity beyond float's range must be refused, not become Inf.
  const double watts_per_sr = l.intensity * double(options_.light_intensity_scale);
  d.radius = options_.light_radius;
  if (!light_intensity_allowed(watts_per_sr, glm::dvec3(color)))
    fail(ErrorCode::invalid_argument,
         node_label(node, inst.node) + ": " + what + ": intensity " + short_double(l.intensity) + " cd (" +
             short_double(watts_per_sr) + " W/sr) x max(1, colour " +
             short_double(std::max({color.r, color.g, color.b})) + ") is more than the limit of " +
             short_double(kMaxLightIntensity) + " W/sr (kMaxLightIntensity, light_policy.h)");
  d.color = glm::vec3(color);
  d.intensity = float(l.intensity * double(options_.light_intensity_scale));
  scene_.lights.push_back(d);
  light_sources_.push_back(
      {node_label(node, inst.node) + ": " + what, position, inst.node, {}, d.directional});
}

// One animation sampler as a KeyTrack in world space and demo frames: the node's parent
// transform carries the keys (a translation T moves the node's origin to parent * T), its
// linear part the cubic tangents, which are per second in glTF and per frame here.
KeyTrack Loader::read_track(const tinygltf::Animation& animation, int sampler, const std::string& what,
                            const glm::dmat4& parent, std::vector<glm::dvec3>& world_keys) const {
  if (sampler < 0 || std::size_t(sampler) >= animation.samplers.size())
    fail(ErrorCode::format_error, what + " refers to sampler " + num(sampler) + "; the animation has " +
                                      num(animation.samplers.size()) + " samplers");
  const tinygltf::AnimationSampler& s = animation.samplers[std::size_t(sampler)];
  KeyTrack track;
  if (s.interpolation.empty() || s.interpolation == "LINEAR")
    track.interpolation = KeyTrack::Interpolation::linear;
  else if (s.interpolation == "STEP")
    track.interpolation = KeyTrack::Interpolation::step;
  else if (s.interpolation == "CUBICSPLINE")
    track.interpolation = KeyTrack::Interpolation::cubic;
  else
    fail(ErrorCode::format_error, what + ": unknown interpolation " + quote(s.interpolation) +
                                      " (glTF has LINEAR, STEP and CUBICSPLINE)");
  const std::vector<float> times = read_floats(s.input, what + " input", 1);
  if (times.empty()) fail(ErrorCode::format_error, what + ": the sampler has no keys");
  for (std::size_t k = 0; k < times.size(); ++k)
    if (!std::isfinite(times[k]) || times[k] < 0.0f || (k > 0 && !(times[k] > times[k - 1])))
      fail(ErrorCode::format_error, what + ": key time " + num(k) + " (" + short_double(double(times[k])) +
                                        ") is not finite, negative or not after the one before; glTF "
                                        "key times are strictly increasing from >= 0");
  const std::size_t per_key = track.interpolation == KeyTrack::Interpolation::cubic ? 3 : 1;
  const std::vector<float> values = read_floats(s.output, what + " output", 3);
  if (values.size() != 3 * per_key * times.size())
    fail(ErrorCode::format_error, what + ": the output has " + num(values.size() / 3) + " values for " +
                                      num(times.size()) + " key times; " + s.interpolation + " needs " +
                                      num(per_key * times.size()));
  const double fps = double(options_.animation_fps);
  const glm::dmat3 linear(parent);
  for (std::size_t k = 0; k < times.size(); ++k) {
    track.times.push_back(float(double(times[k]) * fps));
    if (!std::isfinite(track.times.back()))
      fail(ErrorCode::format_error, what + ": key time " + num(k) + " (" + short_double(double(times[k])) +
                                        " s) is beyond float's range in frames");
  }
  for (std::size_t i = 0; i < values.size() / 3; ++i) {
    const glm::dvec3 v(values[3 * i], values[3 * i + 1], values[3 * i + 2]);
    const bool tangent = per_key == 3 && i % 3 != 1;
    const glm::dvec3 w = tangent ? linear * v / fps : glm::dvec3(parent * glm::dvec4(v, 1.0));
    if (!(std::isfinite(w.x) && std::isfinite(w.y) && std::isfinite(w.z)) ||
        glm::any(glm::greaterThan(glm::abs(w), glm::dvec3(double(std::numeric_limits<float>::max())))))
      fail(ErrorCode::format_error,
           what + ": output value " + num(i) + " is not finite in world space (node transforms overflow)");
    track.values.push_back(glm::vec3(w));
    if (!tangent) world_keys.push_back(w);
  }
  return track;
}

// The animation's duration in seconds, its last key time over all its samplers: every track of
// it loops with this period, as a player loops the whole animation.
double Loader::animation_duration(const tinygltf::Animation& animation, const std::string& what) const {
  double duration = 0.0;
  for (std::size_t i = 0; i < animation.samplers.size(); ++i) {
    const std::vector<float> times =
        read_floats(animation.samplers[i].input, what + " sampler " + num(i) + " input", 1);
    for (const float t : times)
      if (std::isfinite(t)) duration = std::max(duration, double(t));
  }
  return duration;
}

// glTF animations (docs/demo.md, "Animations"): a translation channel of a node carrying a point
// or spot light moves that light, one of the first dynamic node (the key of dynamic_path) moves
// the dynamic meshes; both become KeyTracks the demo samples every frame. Every other channel is
// ignored, and all ignored ones are named in a single warning.
void Loader::read_animations(const std::vector<NodeInstance>& instances) {
  if (model_.animations.empty()) return;
  if (!(std::isfinite(options_.animation_fps) && options_.animation_fps > 0.0f &&
        options_.animation_fps <= 1e6f))
    fail(ErrorCode::invalid_argument,
         "animation_fps " + short_double(double(options_.animation_fps)) + " is not in (0, 1e6]");
  const std::size_t nodes = model_.nodes.size();
  std::vector<const NodeInstance*> instance_of(nodes, nullptr);
  for (const NodeInstance& inst : instances) instance_of[std::size_t(inst.node)] = &inst;
  std::vector<int> parent(nodes, -1);
  for (std::size_t i = 0; i < nodes; ++i)
    for (const int c : model_.nodes[i].children)
      if (c >= 0 && std::size_t(c) < nodes) parent[std::size_t(c)] = int(i);
  std::vector<int> light_of(nodes, -1);
  for (std::size_t i = 0; i < light_sources_.size(); ++i)
    if (light_sources_[i].node >= 0) light_of[std::size_t(light_sources_[i].node)] = int(i);
  // Nodes any channel targets: a node below one of them would move with it, which the demo
  // does not do.
  std::vector<char> animated(nodes, 0);
  for (const tinygltf::Animation& a : model_.animations)
    for (const tinygltf::AnimationChannel& ch : a.channels)
      if (ch.target_node >= 0 && std::size_t(ch.target_node) < nodes)
        animated[std::size_t(ch.target_node)] = 1;
  std::vector<char> played(nodes, 0);
  std::vector<std::string> ignored;
  for (std::size_t ai = 0; ai < model_.animations.size(); ++ai) {
    const tinygltf::Animation& a = model_.animations[ai];
    const std::string name =
        "animation " + num(ai) + (a.name.empty() ? std::string() : " (" + quote(a.name) + ")");
    std::optional<double> duration;
    for (std::size_t ci = 0; ci < a.channels.size(); ++ci) {
      const tinygltf::AnimationChannel& ch = a.channels[ci];
      const std::string channel = name + " channel " + num(ci);
      const int t = ch.target_node;
      if (t < 0 || std::size_t(t) >= nodes) {
        ignored.push_back(channel + " (" + ch.target_path + ", no target node)");
        continue;
      }
      const tinygltf::Node& node = model_.nodes[std::size_t(t)];
      const std::string target = channel + " (" + node_label(node, t) + " " + ch.target_path;
      const int light = light_of[std::size_t(t)];
      const bool dynamic = t == dynamic_key_node_;
      const NodeInstance* inst = instance_of[std::size_t(t)];
      if (!inst) {
        ignored.push_back(target + ", a node outside the scene)");
        continue;
      }
      // Scale and rotation of a light node without children or mesh move nothing (the light is a
      // point at the node's origin); a spot light's rotation would turn its cone.
      const bool bare = node.children.empty() && node.mesh < 0;
      if (light >= 0 && bare && !dynamic &&
          (ch.target_path == "scale" ||
           (ch.target_path == "rotation" && scene_.lights[std::size_t(light)].outer_cone >= 3.14159f)))
        continue;
      if (ch.target_path != "translation" || (light < 0 && !dynamic)) {
        ignored.push_back(target + ")");
        continue;
      }
      bool ancestor_animated = false;
      for (int p = parent[std::size_t(t)], steps = 0; p >= 0 && steps < int(nodes);
           p = parent[std::size_t(p)], ++steps)
        ancestor_animated = ancestor_animated || animated[std::size_t(p)];
      if (ancestor_animated) {
        ignored.push_back(target + ": a parent node is animated too, and the demo moves the node alone)");
        continue;
      }
      if (played[std::size_t(t)]) {
        ignored.push_back(target + ": an earlier channel moves it already)");
        continue;
      }
      played[std::size_t(t)] = 1;
      std::vector<glm::dvec3> keys;
      KeyTrack track = read_track(a, ch.sampler, channel, inst->parent, keys);
      if (!duration) duration = animation_duration(a, name);
      track.period = float(*duration * double(options_.animation_fps));
      if (!std::isfinite(track.period))
        fail(ErrorCode::format_error,
             name + ": its duration " + short_double(*duration) + " s is beyond float's range in frames");
      if (light >= 0) {
        scene_.lights[std::size_t(light)].track = track;
        light_sources_[std::size_t(light)].keys = std::move(keys);
      }
      if (dynamic) scene_.dynamic_track = std::move(track);
      if (!bare && !dynamic)
        ignored.push_back(
            node_label(node, t) + ": its " +
            (node.mesh >= 0 ? (node.children.empty() ? "mesh" : "mesh and children") : "children") +
            " stay where they are (only its light moves)");
      else if (!node.children.empty())
        ignored.push_back(node_label(node, t) +
                          ": its children stay where they are (only its own mesh moves)");
    }
  }
  if (!ignored.empty()) {
    std::string list;
    for (const std::string& i : ignored) list += (list.empty() ? "" : "; ") + i;
    warnings_.push_back(
        "animations: modrt-demo plays the translation of nodes carrying a point or spot light and of the "
        "first "
        "dynamic node (docs/demo.md, \"Animations\"); ignored: " +
        list);
  }
}

// Lights outside the level's bounding box grown by its largest extent (light_position_in_level,
// the contract of every authored light): they light nothing a closed level shows, and positions
// near float's range broke the ray tracer (a lamp at x = 1e19 aborted Embree, issue 18).
void Loader::check_light_positions() const {
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const BlockDescription& b : scene_.level.blocks)
    for (const glm::dvec3& c : block_corners(scene_.level, b)) lo = glm::min(lo, c), hi = glm::max(hi, c);
  for (const LightSource& l : light_sources_)
    for (std::size_t k = 0; k <= l.keys.size() && !l.directional; ++k) {
      const glm::dvec3& p = k == 0 ? l.position : l.keys[k - 1];
      if (!light_position_in_level(p, lo, hi, scene_.level.cell_size))
        fail(ErrorCode::invalid_argument,
             l.what + (k == 0 ? std::string() : ": animation key " + num(k - 1)) + ": the light at " +
                 short_vec3(p) + " is outside the level's box " + short_vec3(lo) + " - " + short_vec3(hi) +
                 " grown by its largest extent " +
                 short_double(std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, scene_.level.cell_size})) +
                 " (light_position_in_level, light_policy.h)");
    }
}

// The renderer draws kMaxDemoLights lights (a shadow map each); the rest are dropped, named in
// one warning.
void Loader::keep_light_limit() {
  if (scene_.lights.size() <= kMaxDemoLights) return;
  std::string names;
  for (std::size_t i = kMaxDemoLights; i < light_sources_.size(); ++i)
    names += (names.empty() ? "" : ", ") + light_sources_[i].what;
  warnings_.push_back(num(scene_.lights.size()) + " lights; modrt-demo renders the first " +
                      num(kMaxDemoLights) +
                      " (one shadow map each; docs/demo.md, \"Lights\"); dropped: " + names);
  scene_.lights.resize(kMaxDemoLights);
  light_sources_.resize(kMaxDemoLights);
}

// A scene without a light (none in the glTF file or its level): a white point light of cell_size^2 W/sr (the
// same irradiance at the same distance in cells, whatever the unit), at 85 % of the height of the block whose
// centre is nearest the middle of the level: inside the level (the middle of its bounding
// box may lie in solid rock) and above the default camera, which stands at the middle of
// block 0.
void Loader::add_default_light() {
  const LevelDescription& level = scene_.level;
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const BlockDescription& b : level.blocks)
    for (const glm::dvec3& c : block_corners(level, b)) lo = glm::min(lo, c), hi = glm::max(hi, c);
  const glm::dvec3 middle = 0.5 * (lo + hi);
  std::size_t best = 0;
  double best_distance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const double d = glm::length(trilinear(block_corners(level, level.blocks[i]), glm::dvec3(0.5)) - middle);
    if (d < best_distance) best_distance = d, best = i;
  }
  const glm::dvec3 position = trilinear(block_corners(level, level.blocks[best]), glm::dvec3(0.5, 0.85, 0.5));
  DemoLight d;
  d.path = {glm::vec3(position)};
  d.intensity = float(level.cell_size * level.cell_size);
  d.radius = options_.light_radius;
  scene_.lights.push_back(d);
  const std::string name = level.blocks[best].name;
  warnings_.push_back(
      "no point or spot light in the glTF scene or its level; lit by a default white point light of " +
      short_double(double(d.intensity)) + " W/sr (cell_size^2) at " + short_vec3(position) + " in block " +
      num(best) + (name.empty() ? std::string() : " (" + quote(name) + ")") +
      " (docs/demo.md, \"Default light\")");
}

void Loader::set_camera(const NodeInstance& inst) {
  const tinygltf::Node& node = model_.nodes[std::size_t(inst.node)];
  if (node.camera < 0 || std::size_t(node.camera) >= model_.cameras.size())
    fail(ErrorCode::format_error, node_label(node, inst.node) + " refers to camera " + num(node.camera) +
                                      "; the file has " + num(model_.cameras.size()) + " cameras");
  const tinygltf::Camera& c = model_.cameras[std::size_t(node.camera)];
  const std::string what =
      "camera " + num(node.camera) + (c.name.empty() ? std::string() : " (" + quote(c.name) + ")");
  DemoCamera cam;
  if (c.type == "perspective") {
    const tinygltf::PerspectiveCamera& p = c.perspective;
    if (!(p.yfov > 0.0 && p.yfov < 3.14159))
      fail(ErrorCode::format_error, what + ": yfov " + short_double(p.yfov) + " must be in (0, pi)");
    if (!(p.znear > 0.0 && std::isfinite(p.znear)))
      fail(ErrorCode::format_error, what + ": znear " + short_double(p.znear) + " must be > 0");
    if (p.zfar != 0.0 && !(p.zfar > p.znear && std::isfinite(p.zfar)))
      fail(ErrorCode::format_error, what + ": zfar " + short_double(p.zfar) + " must be greater than znear");
    cam.yfov = float(p.yfov);
    cam.znear = float(p.znear);
    cam.zfar = p.zfar > 0.0 ? float(p.zfar) : 0.0f;  // 0: infinite, resolved from the scene bounds later
  } else {
    warnings_.push_back(what + ": " + (c.type.empty() ? std::string("untyped") : c.type) +
                        " camera; drawn as a perspective camera with the default field of view");
    cam.zfar = 0.0f;
  }
  // glTF cameras look along their local -Z with +Y up.
  const glm::dmat3 r(inst.world);
  const glm::dvec3 forward = r * glm::dvec3(0, 0, -1), up = r * glm::dvec3(0, 1, 0);
  if (!(glm::length(forward) > 1e-12) || !(glm::length(up) > 1e-12))
    fail(ErrorCode::format_error, what + ": its node transform is singular");
  cam.position = glm::vec3(inst.world[3]);
  cam.target = cam.position + glm::vec3(glm::normalize(forward));
  cam.up = glm::vec3(glm::normalize(up));
  scene_.camera = cam;
  have_camera_ = true;
}

const tinygltf::Value* Loader::scene_level_extras() const {
  if (scene_index_ < 0) return nullptr;
  const tinygltf::Value& extras = model_.scenes[std::size_t(scene_index_)].extras;
  if (!extras.IsObject() || !extras.Has("modrt_level")) return nullptr;
  const tinygltf::Value& v = extras.Get("modrt_level");
  if (!v.IsObject())
    fail(ErrorCode::format_error, "scene " + num(scene_index_) + ": extras.modrt_level must be an object");
  return &v;
}

LevelDescription Loader::level_from_extras(const std::string& path,
                                           const std::vector<BlockNode>& blocks) const {
  std::string text = "{\"format\":\"modrt-level\",\"version\":1";
  double cell_size = 1.0;
  if (const tinygltf::Value* lv = scene_level_extras()) {
    for (const std::string& key : lv->Keys()) {
      if (key == "proxy_walls") continue;
      if (key == "format" || key == "version" || key == "blocks")
        fail(ErrorCode::format_error, "scene " + num(scene_index_) + ": extras.modrt_level." + key +
                                          " is set by the loader; remove it");
      text += ",";
      append_json_string(text, key);
      text += ":";
      append_json(text, lv->Get(key));
      if (key == "cell_size" && lv->Get(key).IsNumber()) cell_size = lv->Get(key).GetNumberAsDouble();
    }
  }
  text += ",\"blocks\":[";
  for (std::size_t bi = 0; bi < blocks.size(); ++bi) {
    const BlockNode& b = blocks[bi];
    const tinygltf::Node& node = model_.nodes[std::size_t(b.node)];
    const std::string label = node_label(node, b.node);
    static const tinygltf::Value empty_object{tinygltf::Value::Object()};
    const tinygltf::Value& spec = b.block->IsObject() ? *b.block : empty_object;
    if (bi) text += ",";
    text += "{";
    bool first = true;
    for (const std::string& key : spec.Keys()) {
      if (key == "draw") continue;
      text += first ? "" : ",";
      first = false;
      append_json_string(text, key);
      text += ":";
      append_json(text, spec.Get(key));
    }
    auto add_field = [&](const std::string& key, const std::string& json_value) {
      text += first ? "" : ",";
      first = false;
      append_json_string(text, key);
      text += ":" + json_value;
    };
    if (!spec.Has("name")) {
      std::string name;
      append_json_string(name, node.name.empty() ? label : node.name);
      add_field("name", name);
    }
    if (!spec.Has("cell")) {
      if (node.mesh < 0)
        fail(ErrorCode::format_error, label +
                                          ": extras.modrt_block has no \"cell\" and the node has no mesh to "
                                          "take the block's corners from");
      if (std::size_t(node.mesh) >= model_.meshes.size())
        fail(ErrorCode::format_error, label + " refers to mesh " + num(node.mesh) + "; the file has " +
                                          num(model_.meshes.size()) + " meshes");
      // The block is the node's mesh bounding box (local frame) carried by its world
      // transform: a rotated, sheared or tapered box gives a warped block.
      glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
      const tinygltf::Mesh& gm = model_.meshes[std::size_t(node.mesh)];
      for (std::size_t pi = 0; pi < gm.primitives.size(); ++pi) {
        const auto it = gm.primitives[pi].attributes.find("POSITION");
        if (it == gm.primitives[pi].attributes.end()) continue;
        const std::vector<float> p = read_floats(it->second, label + " block mesh POSITION", 3);
        for (std::size_t v = 0; v + 2 < p.size(); v += 3) {
          const glm::dvec3 x(p[v], p[v + 1], p[v + 2]);
          lo = glm::min(lo, x), hi = glm::max(hi, x);
        }
      }
      if (!(lo.x <= hi.x))
        fail(ErrorCode::format_error, label + ": extras.modrt_block: the node's mesh has no vertices");
      std::array<glm::dvec3, 8> corners;
      glm::dvec3 centre(0.0);
      for (int k = 0; k < 8; ++k) {
        const glm::dvec3 t(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        corners[std::size_t(k)] = glm::dvec3(b.world * glm::dvec4(lo + t * (hi - lo), 1.0));
        centre += corners[std::size_t(k)] / 8.0;
      }
      const double cs = cell_size > 0.0 && std::isfinite(cell_size) ? cell_size : 1.0;
      const glm::ivec3 cell(glm::floor(centre / cs));
      const std::array<glm::dvec3, 8> grid = grid_cell_corners(cell, cs);
      bool on_grid = true;
      for (int k = 0; k < 8; ++k)
        on_grid = on_grid && glm::length(corners[std::size_t(k)] - grid[std::size_t(k)]) <= 1e-5 * cs;
      add_field("cell", "[" + num(cell.x) + "," + num(cell.y) + "," + num(cell.z) + "]");
      if (!on_grid) {
        std::string list = "[";
        for (int k = 0; k < 8; ++k) list += (k ? "," : "") + json_vec3(corners[std::size_t(k)]);
        add_field("corners", list + "]");
      }
    }
    text += "}";
  }
  text += "]}";
  Result<LevelDescription> level = precompute::parse_level_json(text, path + " (extras.modrt_block)");
  if (!level.ok()) {
    // The level parser names blocks by position; say which nodes those are.
    std::string message = level.status().message(), nodes;
    for (std::size_t bi = 0; bi < blocks.size(); ++bi) {
      const std::string a = "blocks[" + num(bi) + "]", c = "block " + num(bi);
      auto names = [&](const std::string& token) {
        const std::size_t at = message.find(token);
        return at != std::string::npos &&
               (at + token.size() >= message.size() ||
                !std::isdigit(static_cast<unsigned char>(message[at + token.size()])));
      };
      if (names(a) || names(c))
        nodes += (nodes.empty() ? "" : ", ") + c + " is " +
                 node_label(model_.nodes[std::size_t(blocks[bi].node)], blocks[bi].node);
    }
    fail(level.status().code(),
         "level JSON error: " + message + (nodes.empty() ? std::string() : " (" + nodes + ")"));
  }
  return std::move(level).value();
}

DemoScene Loader::load(const std::string& path) {
  for (const std::string& ext : model_.extensionsRequired)
    if (ext != "KHR_lights_punctual" && ext != "KHR_mesh_quantization")
      fail(ErrorCode::format_error,
           "the file requires extension " + ext + ", which the demo does not support");
  for (const std::string& ext : model_.extensionsUsed)
    if (ext != "KHR_lights_punctual" && ext != "KHR_mesh_quantization")
      warnings_.push_back("extension " + ext + " is ignored");

  std::vector<int> roots;
  if (model_.scenes.empty()) {
    if (options_.scene > 0)
      fail(ErrorCode::invalid_argument,
           "scene " + num(options_.scene) + " does not exist; the file has no scenes");
    // No scenes: every node that is nobody's child is a root.
    std::vector<char> child(model_.nodes.size(), 0);
    for (const tinygltf::Node& n : model_.nodes)
      for (int c : n.children)
        if (c >= 0 && std::size_t(c) < child.size()) child[std::size_t(c)] = 1;
    for (std::size_t i = 0; i < model_.nodes.size(); ++i)
      if (!child[i]) roots.push_back(int(i));
  } else {
    scene_index_ = options_.scene >= 0 ? options_.scene : std::max(model_.defaultScene, 0);
    if (std::size_t(scene_index_) >= model_.scenes.size())
      fail(ErrorCode::invalid_argument, "scene " + num(scene_index_) + " does not exist; the file has " +
                                            num(model_.scenes.size()) + " scenes");
    roots = model_.scenes[std::size_t(scene_index_)].nodes;
  }
  scene_.name = fs::path(path).filename().string();
  if (scene_index_ >= 0 && !model_.scenes[std::size_t(scene_index_)].name.empty())
    scene_.name += " (" + model_.scenes[std::size_t(scene_index_)].name + ")";

  convert_materials();
  const std::vector<NodeInstance> instances = traverse(roots);
  check_vertex_buffer_estimate(instances);

  // Dynamic meshes share one path key: the first dynamic node's world translation. Every
  // dynamic mesh keeps its world rotation and scale and is placed relative to that key.
  std::vector<BlockNode> block_nodes;
  for (const NodeInstance& inst : instances) {
    const tinygltf::Node& node = model_.nodes[std::size_t(inst.node)];
    const std::string label = node_label(node, inst.node);
    bool is_block = false, draw_block = false, dynamic = false;
    int clutter = -1;
    if (node.extras.IsObject()) {
      if (node.extras.Has("modrt_block")) {
        const tinygltf::Value& b = node.extras.Get("modrt_block");
        if (b.IsObject()) {
          is_block = true;
          if (b.Has("draw")) {
            const std::optional<bool> draw = extras_bool(b.Get("draw"));
            if (!draw)
              fail(ErrorCode::format_error, label + ": extras.modrt_block.draw must be " + kExtrasBool);
            draw_block = *draw;
          }
        } else if (const std::optional<bool> flag = extras_bool(b)) {
          is_block = *flag;
        } else {
          fail(ErrorCode::format_error, label + ": extras.modrt_block must be an object (or true or 1)");
        }
        if (is_block) block_nodes.push_back({inst.node, inst.world, &b});
      }
    }
    // tinygltf drops empty objects from extras: `"modrt_block": {}` would vanish silently.
    if (!node.extras.IsObject() || !node.extras.Has("modrt_block")) {
      const std::string& raw = node.extras_json_string;
      if (raw.find("\"modrt_block\"") != std::string::npos)
        fail(ErrorCode::format_error,
             label +
                 ": extras.modrt_block is empty or null; write true for a block with "
                 "default fields, or give its fields");
    }
    if (node.extras.IsObject()) {
      if (node.extras.Has("modrt_dynamic")) {
        const std::optional<bool> d = extras_bool(node.extras.Get("modrt_dynamic"));
        if (!d) fail(ErrorCode::format_error, label + ": extras.modrt_dynamic must be " + kExtrasBool);
        dynamic = *d;
      }
    }
    if (is_block && dynamic)
      fail(ErrorCode::format_error, label + ": a node cannot be both a proxy block and dynamic");
    const bool clutter_false = node.extras.IsObject() && node.extras.Has("modrt_clutter") &&
                               extras_bool(node.extras.Get("modrt_clutter")) == false;
    if (node.extras.IsObject() && node.extras.Has("modrt_clutter") && !clutter_false) {
      ClutterNode c;
      c.node = inst.node;
      c.label = label;
      read_clutter_extras(node.extras.Get("modrt_clutter"), c);
      if (is_block || dynamic)
        fail(ErrorCode::format_error, label + ": extras.modrt_clutter: a clutter node cannot also be " +
                                          (is_block ? "a proxy block" : "dynamic"));
      if (node.mesh < 0)
        fail(ErrorCode::format_error, label + ": extras.modrt_clutter: the node has no mesh");
      clutter = int(clutter_nodes_.size());
      clutter_nodes_.push_back(std::move(c));
    } else if (!clutter_false && node.extras_json_string.find("\"modrt_clutter\"") != std::string::npos) {
      fail(ErrorCode::format_error, label +
                                        ": extras.modrt_clutter is empty or null; write true for a clutter "
                                        "object with default fields, or give its fields");
    }
    if (node.skin >= 0) warnings_.push_back(label + ": skin ignored; the mesh is drawn unskinned");
    if (node.camera >= 0 && !have_camera_) set_camera(inst);
    if (auto it = node.extensions.find("KHR_lights_punctual"); it != node.extensions.end()) {
      if (!it->second.IsObject() || !it->second.Has("light") || !it->second.Get("light").IsInt())
        fail(ErrorCode::format_error, label + ": KHR_lights_punctual needs an integer \"light\"");
      add_light(inst, it->second.Get("light").Get<int>());
    }
    if (node.mesh < 0 || (is_block && !draw_block)) continue;
    if (dynamic) {
      if (!have_dynamic_key_) {
        have_dynamic_key_ = true;
        dynamic_key_ = glm::dvec3(inst.world[3]);
        dynamic_key_node_ = inst.node;
      }
      glm::dmat4 relative = inst.world;
      relative[3] -= glm::dvec4(dynamic_key_, 0.0);
      add_mesh(inst.node, relative, true);
    } else {
      add_mesh(inst.node, inst.world, false, clutter);
    }
  }
  if (have_dynamic_key_) scene_.dynamic_path = {glm::vec3(dynamic_key_)};

  // The proxy blocks: an explicit level file, the sidecar, or the marked nodes.
  const std::string sidecar = gltf_sidecar_level_path(path);
  std::error_code ec;
  std::string level_file = options_.level_path;
  if (level_file.empty() && fs::exists(sidecar, ec)) level_file = sidecar;
  if (!level_file.empty()) {
    Result<LevelDescription> level = precompute::load_level_json(level_file);
    if (!level.ok()) fail(level.status().code(), "level JSON error: " + level.status().message());
    scene_.level = std::move(level).value();
    if (!block_nodes.empty())
      warnings_.push_back(num(block_nodes.size()) +
                          " nodes marked extras.modrt_block are ignored as proxies: the "
                          "blocks come from " +
                          level_file);
  } else if (!block_nodes.empty()) {
    scene_.level = level_from_extras(path, block_nodes);
  }
  bool imported_level = false;
  if (scene_.level.blocks.empty() && level_file.empty() && block_nodes.empty() && options_.import_unmarked) {
    // No modrt markup: the proxy blocks come from the scene's own geometry (docs/import.md).
    Result<precompute::SceneImport> imported = import_scene_level(scene_, options_.import_settings);
    if (!imported.ok())
      fail(imported.status().code(),
           "no proxy blocks in the file, and importing them from its geometry failed: " +
               imported.status().message());
    for (const std::string& w : imported->warnings) warnings_.push_back("import: " + w);
    if (options_.import_result) *options_.import_result = std::move(imported).value();
    imported_level = true;
  }
  if (scene_.level.blocks.empty())
    fail(ErrorCode::format_error,
         "no proxy blocks found: mark nodes with extras.modrt_block or add a level file " + sidecar +
             (level_file.empty() ? std::string() : " (" + level_file + " has no blocks)"));

  make_clutter_objects();

  // An imported level's walls are the scene's own: the proxies are not drawn over them.
  bool walls = !imported_level;
  if (const tinygltf::Value* lv = scene_level_extras(); lv && lv->Has("proxy_walls")) {
    const std::optional<bool> flag = extras_bool(lv->Get("proxy_walls"));
    if (!flag)
      fail(ErrorCode::format_error,
           "scene " + num(scene_index_) + ": extras.modrt_level.proxy_walls must be " + kExtrasBool);
    walls = *flag;
  }
  if (options_.proxy_walls) walls = *options_.proxy_walls;
  if (walls) add_wall_meshes(scene_, options_.wall_subdivisions);

  // Scene bounds: the proxy blocks (they enclose the scene) and the static meshes.
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const BlockDescription& b : scene_.level.blocks)
    for (const glm::dvec3& c : block_corners(scene_.level, b)) lo = glm::min(lo, c), hi = glm::max(hi, c);
  for (const Mesh& m : scene_.meshes)
    if (!m.dynamic)
      for (const glm::vec3& p : m.position)
        lo = glm::min(lo, glm::dvec3(p)), hi = glm::max(hi, glm::dvec3(p));
  const double diagonal = glm::length(hi - lo);
  if (!have_camera_) {
    // No camera: stand in the middle of the first block, looking at the middle of the level
    // (or along +Z when that is straight up or down, or the same point).
    const BlockDescription& b0 = scene_.level.blocks.front();
    const glm::dvec3 eye = trilinear(block_corners(scene_.level, b0), glm::dvec3(0.5));
    glm::dvec3 dir = 0.5 * (lo + hi) - eye;
    dir.y = 0.0;
    if (glm::length(dir) < 1e-3 * scene_.level.cell_size) dir = glm::dvec3(0, 0, 1);
    scene_.camera = DemoCamera{};
    scene_.camera.position = glm::vec3(eye);
    scene_.camera.target = glm::vec3(eye + glm::normalize(dir));
    scene_.camera.up = glm::vec3(0, 1, 0);
    warnings_.push_back("no camera in the glTF scene; using one in the middle of the first proxy block");
  }
  if (scene_.camera.zfar == 0.0f)
    scene_.camera.zfar = float(std::max(double(DemoCamera{}.zfar), 2.0 * diagonal));

  if (scene_.lights.empty()) {
    // The level file's lights stand in when the glTF file has no point light.
    for (std::size_t i = 0; i < scene_.level.lights.size(); ++i) {
      const LightDescription& l = scene_.level.lights[i];
      const std::string what = "level light " + num(i);
      DemoLight d;
      d.radius = l.radius > 0.0 ? float(l.radius) : options_.light_radius;
      if (!light_intensity_allowed(l.intensity, l.color))
        fail(ErrorCode::invalid_argument, what + ": intensity " + short_double(l.intensity) +
                                              " W/sr x max(1, colour) is more than the limit of " +
                                              short_double(kMaxLightIntensity) + " W/sr (light_policy.h)");
      d.path = {glm::vec3(l.position)};
      d.color = glm::vec3(l.color);
      d.intensity = float(l.intensity);
      scene_.lights.push_back(d);
      light_sources_.push_back({what, l.position, -1, {}});
    }
  }
  read_animations(instances);
  check_light_positions();
  keep_light_limit();
  if (scene_.lights.empty()) add_default_light();
  return std::move(scene_);
}

}  // namespace

Result<DemoScene> load_gltf_scene(const std::string& path, const GltfSceneOptions& options) {
  try {
    // LoadBinaryFromMemory and LoadASCIIFromString take the length as unsigned int.
    const std::size_t cap =
        std::min<std::size_t>(options.max_file_bytes, std::numeric_limits<unsigned int>::max());
    std::vector<unsigned char> bytes = read_file_capped(path, cap);
    LoaderContext ctx{options.max_file_bytes, options.max_image_side};
    tinygltf::TinyGLTF gltf;
    tinygltf::FsCallbacks callbacks{&tinygltf::FileExists, &tinygltf::ExpandFilePath, &read_whole_file_capped,
                                    &tinygltf::WriteWholeFile, &ctx};
    gltf.SetFsCallbacks(callbacks);
    gltf.SetImageLoader(&load_image_checked, &ctx);
    gltf.SetStoreOriginalJSONForExtrasAndExtensions(true);  // see the empty modrt_block check
    tinygltf::Model model;
    std::string err, warn;
    const std::string base_dir = fs::path(path).parent_path().string();
    const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    {
      // The JSON text: the whole file, or a glb's first chunk (tinygltf checks the rest).
      const unsigned char* json = bytes.data();
      std::size_t json_size = bytes.size();
      if (binary) {
        json_size =
            bytes.size() >= 20 ? std::min<std::size_t>(le32(bytes.data() + 12), bytes.size() - 20) : 0;
        json = bytes.data() + std::min<std::size_t>(20, bytes.size());
      }
      if (json_depth(json, json_size) > kMaxJsonDepth)
        return Status::error(ErrorCode::format_error, path + ": JSON nested deeper than " +
                                                          num(kMaxJsonDepth) + " levels; not a glTF file");
    }
    bytes = resolve_uris(std::move(bytes), binary);
    if (bytes.size() > cap)
      return Status::error(ErrorCode::resource_limit, path + ": the file is larger than the limit of " +
                                                          num(cap) + " bytes with its URIs re-escaped");
    const bool ok =
        binary
            ? gltf.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(), unsigned(bytes.size()), base_dir)
            : gltf.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(bytes.data()),
                                       unsigned(bytes.size()), base_dir);
    if (!ok)
      return Status::error(ErrorCode::format_error,
                           path + ": tinygltf could not load the " + (binary ? "glb" : "glTF") +
                               " file: " + (err.empty() ? std::string("no reason given") : join_lines(err)) +
                               (warn.empty() ? std::string() : " (warnings: " + join_lines(warn) + ")"));
    Loader loader(model, options, warn);
    DemoScene scene = loader.load(path);
    if (options.warnings) {
      for (const std::string& w : split_lines(warn)) options.warnings->push_back(path + ": tinygltf: " + w);
      for (const std::string& w : loader.warnings()) options.warnings->push_back(path + ": " + w);
    }
    return scene;
  } catch (const LoadFailure& f) {
    return Status::error(f.code, path + ": " + f.message);
  } catch (const std::bad_alloc&) {
    return Status::error(ErrorCode::resource_limit, path + ": out of memory while loading the glTF scene");
  } catch (const std::exception& e) {
    return Status::error(ErrorCode::internal_error,
                         path + ": unexpected error while loading the glTF scene: " + e.what());
  }
}

}  // namespace modrt::demo
