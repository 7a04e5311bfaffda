// SPDX-License-Identifier: MIT
// modrt precompute — level JSON reader and writer (docs/level-format.md).
#include "modrt/precompute/level_json.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <span>
#include <utility>
#include <vector>

#include <glm/common.hpp>
#include <nlohmann/json.hpp>

#include "modrt/file_io.h"
#include "modrt/level.h"
#include "modrt/light_policy.h"

namespace modrt::precompute {
namespace {

using json = nlohmann::json;
using ordered_json = nlohmann::ordered_json;

constexpr int kMaxCellCoordinate = (1 << 20) - 1;  // validate_level's limit
constexpr glm::dvec3 kDefaultAlbedo{kDefaultFaceAlbedo, kDefaultFaceAlbedo, kDefaultFaceAlbedo};

// Internal: thrown by the helpers below, caught in parse_level_json.
struct ParseFailure {
  ErrorCode code;
  std::string message;
};

bool is_identifier(const std::string& key) {
  if (key.empty()) return false;
  for (std::size_t i = 0; i < key.size(); ++i) {
    const char c = key[i];
    const bool alpha = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
    const bool digit = c >= '0' && c <= '9';
    if (!(alpha || (i > 0 && digit))) return false;
  }
  return true;
}

std::string quote(const std::string& s) {
  return json(s).dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string key_path(const std::string& parent, const std::string& key) {
  return parent + (parent.empty() ? "" : ".") + (is_identifier(key) ? key : quote(key));
}

std::string index_path(const std::string& parent, std::size_t i) {
  return parent + "[" + std::to_string(i) + "]";
}

std::string fmt_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

const char* type_name(const json& j) {
  switch (j.type()) {
    case json::value_t::null: return "null";
    case json::value_t::object: return "an object";
    case json::value_t::array: return "an array";
    case json::value_t::string: return "a string";
    case json::value_t::boolean: return "a boolean";
    case json::value_t::binary: return "binary data";
    case json::value_t::discarded: return "a discarded value";
    default: return "a number";
  }
}

// Levenshtein distance, for "did you mean" suggestions.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

constexpr std::array<const char*, kFaceCount> kFaceNames = {"-X", "+X", "-Y", "+Y", "-Z", "+Z"};

int face_from_name(const std::string& s) {
  for (int f = 0; f < kFaceCount; ++f)
    if (s == kFaceNames[f]) return f;
  return -1;
}

class Parser {
 public:
  explicit Parser(const std::string& what) : what_(what) {}

  [[noreturn]] void fail(ErrorCode code, const std::string& path, const std::string& problem) const {
    throw ParseFailure{code,
                       what_ + ": " + (path.empty() ? std::string("top level") : path) + ": " + problem};
  }

  const json& expect(const json& j, const std::string& path, json::value_t type, const char* want) const {
    const bool ok = type == json::value_t::number_float ? j.is_number() : j.type() == type;
    if (!ok) fail(ErrorCode::format_error, path, std::string("expected ") + want + ", got " + type_name(j));
    return j;
  }

  // Fails on keys not in `allowed` (keys starting with '_' are comments and ignored).
  void check_fields(const json& obj, const std::string& path,
                    std::initializer_list<const char*> allowed) const {
    for (const auto& [key, value] : obj.items()) {
      if (!key.empty() && key[0] == '_') continue;
      bool known = false;
      for (const char* a : allowed) known = known || key == a;
      if (known) continue;
      std::string list, best;
      std::size_t best_d = 3;  // suggest only close matches
      for (const char* a : allowed) {
        list += (list.empty() ? "" : ", ") + std::string(a);
        const std::size_t d = edit_distance(key, a);
        if (d < best_d) best_d = d, best = a;
      }
      fail(ErrorCode::format_error, key_path(path, key),
           "unknown field " + quote(key) + (best.empty() ? "" : " (did you mean " + quote(best) + "?)") +
               "; allowed here: " + list);
    }
  }

  const json* find(const json& obj, const char* key) const {
    const auto it = obj.find(key);
    return it == obj.end() ? nullptr : &*it;
  }

  const json& require(const json& obj, const std::string& path, const char* key) const {
    const json* v = find(obj, key);
    if (!v) fail(ErrorCode::format_error, path, std::string("missing required field ") + quote(key));
    return *v;
  }

  double number(const json& j, const std::string& path) const {
    expect(j, path, json::value_t::number_float, "a number");
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(ErrorCode::invalid_argument, path, "number is not finite");
    return v;
  }

  double number_in(const json& j, const std::string& path, double lo, double hi, const char* range) const {
    const double v = number(j, path);
    if (!(v >= lo && v <= hi))
      fail(ErrorCode::invalid_argument, path, fmt_double(v) + " is outside " + range);
    return v;
  }

  int integer(const json& j, const std::string& path, int lo, int hi) const {
    expect(j, path, json::value_t::number_float, "an integer");
    double v;
    if (j.is_number_unsigned()) {
      const auto u = j.get<std::uint64_t>();
      v = u > std::uint64_t(1) << 53 ? std::numeric_limits<double>::infinity() : double(u);
    } else if (j.is_number_integer()) {
      const auto s = j.get<std::int64_t>();
      v = (s > (std::int64_t(1) << 53) || s < -(std::int64_t(1) << 53))
              ? std::numeric_limits<double>::infinity()
              : double(s);
    } else {
      v = j.get<double>();
      if (std::isfinite(v) && v != std::floor(v))
        fail(ErrorCode::format_error, path, "expected an integer, got " + fmt_double(v));
    }
    if (!(v >= lo && v <= hi))
      fail(ErrorCode::invalid_argument, path,
           j.dump() + " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return int(v);
  }

  const json& array(const json& j, const std::string& path, std::size_t size, const char* of) const {
    expect(j, path, json::value_t::array, "an array");
    if (size != 0 && j.size() != size)
      fail(ErrorCode::format_error, path,
           "expected an array of " + std::to_string(size) + " " + of + ", got " + std::to_string(j.size()) +
               (j.size() == 1 ? " element" : " elements"));
    return j;
  }

  glm::dvec3 vec3(const json& j, const std::string& path) const {
    array(j, path, 3, "numbers [x, y, z]");
    return {number(j[0], index_path(path, 0)), number(j[1], index_path(path, 1)),
            number(j[2], index_path(path, 2))};
  }

  // RGB with each channel in [lo, hi].
  glm::dvec3 rgb(const json& j, const std::string& path, double hi) const {
    array(j, path, 3, "numbers [r, g, b]");
    const std::string range_text = "[0, " + fmt_double(hi) + "]";
    const char* range = range_text.c_str();
    glm::dvec3 c;
    for (int ch = 0; ch < 3; ++ch)
      c[ch] = number_in(j[std::size_t(ch)], index_path(path, std::size_t(ch)), 0.0, hi, range);
    return c;
  }

  std::string string(const json& j, const std::string& path) const {
    expect(j, path, json::value_t::string, "a string");
    return j.get<std::string>();
  }

  FaceMask face_list(const json& j, const std::string& path) const {
    array(j, path, 0, "");
    FaceMask mask = 0;
    for (std::size_t i = 0; i < j.size(); ++i) {
      const std::string p = index_path(path, i);
      const std::string s = string(j[i], p);
      const int f = face_from_name(s);
      if (f < 0)
        fail(ErrorCode::format_error, p,
             "unknown face name " + quote(s) + " (faces are -X, +X, -Y, +Y, -Z, +Z)");
      if (face_present(mask, f)) fail(ErrorCode::format_error, p, "face " + s + " is listed twice");
      mask = FaceMask(mask | (1u << f));
    }
    return mask;
  }

  BlockDescription block(const json& j, const std::string& path, const glm::dvec3& default_albedo) const {
    expect(j, path, json::value_t::object, "an object (a block)");
    check_fields(j, path, {"name", "cell", "missing", "present", "albedo", "corners"});
    BlockDescription b;
    if (const json* v = find(j, "name")) b.name = string(*v, key_path(path, "name"));
    {
      const std::string p = key_path(path, "cell");
      const json& c = array(require(j, path, "cell"), p, 3, "integers [x, y, z]");
      for (int a = 0; a < 3; ++a)
        b.cell[a] = integer(c[std::size_t(a)], index_path(p, std::size_t(a)), -kMaxCellCoordinate,
                            kMaxCellCoordinate);
    }
    const json* missing = find(j, "missing");
    const json* present = find(j, "present");
    if (missing && present)
      fail(ErrorCode::format_error, path, "give either \"missing\" or \"present\", not both");
    if (missing) b.faces = FaceMask(kAllFaces & ~face_list(*missing, key_path(path, "missing")));
    if (present) b.faces = face_list(*present, key_path(path, "present"));

    b.albedo.fill(default_albedo);
    if (const json* a = find(j, "albedo")) {
      const std::string p = key_path(path, "albedo");
      if (a->is_array()) {
        b.albedo.fill(rgb(*a, p, 1.0));
      } else {
        expect(*a, p, json::value_t::object, "[r, g, b] or an object of per-face colours");
        // Precedence: a face's own entry, then "walls" (side faces), then "default".
        for (const auto& [key, value] : a->items()) {
          if (!key.empty() && key[0] == '_') continue;
          if (key != "default" && key != "walls" && face_from_name(key) < 0)
            fail(ErrorCode::format_error, key_path(p, key),
                 "unknown face name " + quote(key) + " (expected -X, +X, -Y, +Y, -Z, +Z, walls or default)");
        }
        if (const json* d = find(*a, "default")) b.albedo.fill(rgb(*d, key_path(p, "default"), 1.0));
        if (const json* w = find(*a, "walls")) {
          const glm::dvec3 c = rgb(*w, key_path(p, "walls"), 1.0);
          for (int f : {0, 1, 4, 5}) b.albedo[std::size_t(f)] = c;
        }
        for (int f = 0; f < kFaceCount; ++f)
          if (const json* v = find(*a, kFaceNames[f]))
            b.albedo[std::size_t(f)] = rgb(*v, key_path(p, kFaceNames[f]), 1.0);
      }
    }
    if (const json* c = find(j, "corners")) {
      const std::string p = key_path(path, "corners");
      array(*c, p, 8, "corners [x, y, z] (index x + 2y + 4z)");
      b.warped = true;
      for (std::size_t k = 0; k < 8; ++k) b.corners[k] = vec3((*c)[k], index_path(p, k));
    }
    return b;
  }

  // A light (light_policy.h): the centre within the level's box [lo, hi] grown by its largest
  // extent (light_position_in_level; `empty`: no blocks, only the traceable bound), the radius at
  // most that growth, intensity x max(1, colour) <= kMaxLightIntensity.
  LightDescription light(const json& j, const std::string& path, const glm::dvec3& lo, const glm::dvec3& hi,
                         double cell_size, bool empty) const {
    expect(j, path, json::value_t::object, "an object (a light)");
    check_fields(j, path, {"position", "radius", "color", "intensity"});
    LightDescription l;
    const std::string position_path = key_path(path, "position");
    l.position = vec3(require(j, path, "position"), position_path);
    const double grow = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, cell_size});
    auto text = [](const glm::dvec3& v) {
      return "[" + fmt_double(v.x) + ", " + fmt_double(v.y) + ", " + fmt_double(v.z) + "]";
    };
    if (empty ? !traceable(l.position) : !light_position_in_level(l.position, lo, hi, cell_size))
      fail(
          ErrorCode::invalid_argument, position_path,
          text(l.position) + " is outside " +
              (empty ? "[-" + fmt_double(kMaxTraceCoordinate) + ", " + fmt_double(kMaxTraceCoordinate) + "]^3"
                     : "the level's box " + text(lo) + " - " + text(hi) + " grown by " + fmt_double(grow)));
    const double max_radius = empty ? kMaxTraceCoordinate : grow;
    if (const json* v = find(j, "radius"))
      l.radius = number_in(*v, key_path(path, "radius"), 0.0, max_radius,
                           ("[0, " + fmt_double(max_radius) + "]").c_str());
    if (const json* v = find(j, "color")) l.color = rgb(*v, key_path(path, "color"), kMaxLightIntensity);
    const std::string range = "[0, " + fmt_double(kMaxLightIntensity) + "]";
    if (const json* v = find(j, "intensity"))
      l.intensity = number_in(*v, key_path(path, "intensity"), 0.0, kMaxLightIntensity, range.c_str());
    const double power = l.intensity * std::max({1.0, l.color.x, l.color.y, l.color.z});
    if (!light_brightness_allowed(l.intensity, l.color))
      fail(ErrorCode::invalid_argument, key_path(path, "intensity"),
           "intensity x max(1, color) = " + fmt_double(power) + " exceeds " + fmt_double(kMaxLightIntensity));
    if (!light_in_reach(l.position, l.radius))
      fail(ErrorCode::invalid_argument, key_path(path, "radius"),
           fmt_double(l.radius) + " puts the sphere beyond +-" + fmt_double(kMaxTraceCoordinate));
    return l;
  }

  LevelDescription level(const json& root) const {
    expect(root, "", json::value_t::object, "a JSON object (a modrt level)");
    const std::string format = string(require(root, "", "format"), "format");
    if (format != kLevelFormatName)
      fail(ErrorCode::format_error, "format",
           "is " + quote(format) + "; a level file has \"format\": \"" + kLevelFormatName + "\"");
    const int version = integer(require(root, "", "version"), "version", std::numeric_limits<int>::min(),
                                std::numeric_limits<int>::max());
    if (version != kLevelFormatVersion)
      fail(ErrorCode::version_mismatch, "version",
           "version " + std::to_string(version) + " is not supported; this build reads version " +
               std::to_string(kLevelFormatVersion));
    check_fields(root, "", {"format", "version", "name", "cell_size", "default_albedo", "blocks", "lights"});

    LevelDescription level;
    level.version = version;
    if (const json* v = find(root, "name")) level.name = string(*v, "name");
    if (const json* v = find(root, "cell_size"))
      level.cell_size =
          number_in(*v, "cell_size", kMinCellSize, kMaxCellSize,
                    ("[" + fmt_double(kMinCellSize) + ", " + fmt_double(kMaxCellSize) + "]").c_str());
    glm::dvec3 default_albedo = kDefaultAlbedo;
    if (const json* v = find(root, "default_albedo")) default_albedo = rgb(*v, "default_albedo", 1.0);

    const json& blocks = array(require(root, "", "blocks"), "blocks", 0, "");
    level.blocks.reserve(blocks.size());
    for (std::size_t i = 0; i < blocks.size(); ++i)
      level.blocks.push_back(block(blocks[i], index_path("blocks", i), default_albedo));
    if (const json* lights = find(root, "lights")) {
      array(*lights, "lights", 0, "");
      // The level's box: every block's cell (x cell_size) or warp corners.
      glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
      for (const BlockDescription& b : level.blocks) {
        if (b.warped) {
          for (const glm::dvec3& c : b.corners) lo = glm::min(lo, c), hi = glm::max(hi, c);
        } else {
          lo = glm::min(lo, glm::dvec3(b.cell) * level.cell_size);
          hi = glm::max(hi, (glm::dvec3(b.cell) + 1.0) * level.cell_size);
        }
      }
      const bool empty = level.blocks.empty();
      if (empty) lo = hi = glm::dvec3(0.0);
      for (std::size_t i = 0; i < lights->size(); ++i)
        level.lights.push_back(light((*lights)[i], index_path("lights", i), lo, hi, level.cell_size, empty));
    }
    return level;
  }

 private:
  std::string what_;
};

// Parser callback state: tracks the JSON path to report duplicate keys (which nlohmann
// would otherwise silently resolve to the last one).
class DuplicateKeyCheck {
 public:
  explicit DuplicateKeyCheck(const std::string& what) : what_(what) {}

  bool operator()(int /*depth*/, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start: frames_.push_back({false, 0, {}, {}}); break;
      case json::parse_event_t::array_start: frames_.push_back({true, 0, {}, {}}); break;
      case json::parse_event_t::key:
        if (!frames_.empty()) {
          Frame& top = frames_.back();
          top.key = parsed.is_string() ? parsed.get<std::string>() : parsed.dump();
          if (!top.keys.insert(top.key).second) {
            const std::string p = path();
            throw ParseFailure{ErrorCode::format_error,
                               what_ + ": " + p + ": duplicate key " + quote(top.key)};
          }
        }
        break;
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        if (!frames_.empty()) frames_.pop_back();
        element_done();
        break;
      case json::parse_event_t::value: element_done(); break;
    }
    return true;
  }

 private:
  struct Frame {
    bool array;
    std::size_t index;
    std::string key;
    std::set<std::string> keys;
  };

  void element_done() {
    if (!frames_.empty() && frames_.back().array) ++frames_.back().index;
  }

  std::string path() const {
    std::string p;
    for (const Frame& f : frames_) p = f.array ? index_path(p, f.index) : key_path(p, f.key);
    return p;
  }

  std::string what_;
  std::vector<Frame> frames_;
};

// Inserts a space after ':' and ',' outside strings: {"a": [1, 2]}.
std::string spaced(const std::string& compact) {
  std::string out;
  out.reserve(compact.size() + compact.size() / 4);
  bool in_string = false, escape = false;
  for (const char c : compact) {
    out += c;
    if (in_string) {
      if (escape)
        escape = false;
      else if (c == '\\')
        escape = true;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == ':' || c == ',') {
      out += ' ';
    }
  }
  return out;
}

ordered_json rgb_json(const glm::dvec3& c) { return ordered_json::array({c.x, c.y, c.z}); }

using Rgb = std::array<double, 3>;
Rgb key_of(const glm::dvec3& c) { return {c.x, c.y, c.z}; }

// The most frequent colour (first seen wins ties), or `fallback` for an empty list.
template <class Range>
glm::dvec3 most_common(const Range& colours, const glm::dvec3& fallback) {
  std::map<Rgb, std::pair<std::size_t, std::size_t>> count;  // colour -> (count, first seen)
  std::size_t order = 0;
  for (const glm::dvec3& c : colours) {
    auto [it, inserted] = count.emplace(key_of(c), std::make_pair(std::size_t(0), order++));
    ++it->second.first;
  }
  const std::pair<const Rgb, std::pair<std::size_t, std::size_t>>* best = nullptr;
  for (const auto& entry : count) {
    if (!best || entry.second.first > best->second.first ||
        (entry.second.first == best->second.first && entry.second.second < best->second.second))
      best = &entry;
  }
  return best ? glm::dvec3(best->first[0], best->first[1], best->first[2]) : fallback;
}

bool same(const glm::dvec3& a, const glm::dvec3& b) { return key_of(a) == key_of(b); }

// "[json.exception.parse_error.101] parse error at ..." -> "parse error at ...".
std::string strip_prefix(const char* what) {
  std::string msg = what;
  if (const auto pos = msg.find("] "); msg.rfind("[json.exception.", 0) == 0 && pos != std::string::npos)
    msg.erase(0, pos + 2);
  return msg;
}

}  // namespace

Result<LevelDescription> parse_level_json(std::string_view text, const std::string& what) {
  if (text.size() > kMaxLevelFileBytes)
    return Status::error(ErrorCode::resource_limit,
                         what + ": level text is " + std::to_string(text.size()) + " bytes; the limit is " +
                             std::to_string(kMaxLevelFileBytes) + " bytes (64 MiB)");
  try {
    json root;
    try {
      root = json::parse(text.begin(), text.end(), DuplicateKeyCheck(what), /*allow_exceptions=*/true,
                         /*ignore_comments=*/true);
    } catch (const json::parse_error& e) {
      return Status::error(
          ErrorCode::format_error,
          what + ": malformed JSON at byte " + std::to_string(e.byte) + ": " + strip_prefix(e.what()));
    } catch (const json::exception& e) {  // e.g. number overflow (out_of_range.406)
      return Status::error(ErrorCode::format_error, what + ": malformed JSON: " + strip_prefix(e.what()));
    }
    LevelDescription level = Parser(what).level(root);
    Result<LevelConnectivity> valid = validate_level(level);
    if (!valid.ok())
      return Status::error(valid.status().code(),
                           what + ": " + valid.status().message() + " (block N is blocks[N] in the file)");
    return level;
  } catch (const ParseFailure& f) {
    return Status::error(f.code, f.message);
  } catch (const std::bad_alloc&) {
    return Status::error(ErrorCode::resource_limit, what + ": out of memory while parsing");
  } catch (const std::exception& e) {
    return Status::error(ErrorCode::internal_error, what + ": unexpected error while parsing: " + e.what());
  }
}

Result<LevelDescription> load_level_json(const std::string& path) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) return Status::error(ErrorCode::io_error, path + ": cannot read level file: " + ec.message());
  if (size > kMaxLevelFileBytes)
    return Status::error(ErrorCode::resource_limit,
                         path + ": level file is " + std::to_string(size) + " bytes; the limit is " +
                             std::to_string(kMaxLevelFileBytes) + " bytes (64 MiB)");
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::error(ErrorCode::io_error, path + ": cannot open level file");
  std::string text;
  text.resize(std::size_t(size) + 1);  // one extra byte detects a file that grew meanwhile
  in.read(text.data(), std::streamsize(text.size()));
  if (in.bad()) return Status::error(ErrorCode::io_error, path + ": error while reading level file");
  text.resize(std::size_t(in.gcount()));
  if (text.size() > size && text.size() > kMaxLevelFileBytes)
    return Status::error(ErrorCode::resource_limit, path + ": level file grew beyond 64 MiB while reading");
  return parse_level_json(text, path);
}

std::string level_to_json(const LevelDescription& level) {
  std::vector<glm::dvec3> all;
  all.reserve(level.blocks.size() * kFaceCount);
  for (const BlockDescription& b : level.blocks) all.insert(all.end(), b.albedo.begin(), b.albedo.end());
  const glm::dvec3 level_default = most_common(all, kDefaultAlbedo);

  std::string out = "{\n";
  const auto field = [&out](const char* key, const ordered_json& value) {
    out +=
        "  " + quote(key) + ": " + spaced(value.dump(-1, ' ', false, json::error_handler_t::replace)) + ",\n";
  };
  field("format", kLevelFormatName);
  field("version", level.version);
  field("name", level.name);
  field("cell_size", level.cell_size);
  field("default_albedo", rgb_json(level_default));

  out += "  \"blocks\": [";
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const BlockDescription& b = level.blocks[i];
    ordered_json j = ordered_json::object();
    if (!b.name.empty()) j["name"] = b.name;
    j["cell"] = ordered_json::array({b.cell.x, b.cell.y, b.cell.z});
    if ((b.faces & kAllFaces) != kAllFaces) {
      ordered_json missing = ordered_json::array();
      for (int f = 0; f < kFaceCount; ++f)
        if (!face_present(b.faces, f)) missing.push_back(kFaceNames[std::size_t(f)]);
      j["missing"] = missing;
    }
    const glm::dvec3 block_default = most_common(b.albedo, level_default);
    ordered_json albedo = ordered_json::object();
    if (!same(block_default, level_default)) albedo["default"] = rgb_json(block_default);
    for (int f = 0; f < kFaceCount; ++f)
      if (!same(b.albedo[std::size_t(f)], block_default))
        albedo[kFaceNames[std::size_t(f)]] = rgb_json(b.albedo[std::size_t(f)]);
    if (!albedo.empty()) j["albedo"] = albedo;
    if (b.warped) {
      ordered_json corners = ordered_json::array();
      for (const glm::dvec3& c : b.corners) corners.push_back(rgb_json(c));
      j["corners"] = corners;
    }
    out += (i == 0 ? "\n    " : ",\n    ") + spaced(j.dump(-1, ' ', false, json::error_handler_t::replace));
  }
  out += level.blocks.empty() ? "],\n" : "\n  ],\n";

  out += "  \"lights\": [";
  for (std::size_t i = 0; i < level.lights.size(); ++i) {
    const LightDescription& l = level.lights[i];
    ordered_json j = ordered_json::object();
    j["position"] = rgb_json(l.position);
    j["radius"] = l.radius;
    j["color"] = rgb_json(l.color);
    j["intensity"] = l.intensity;
    out += (i == 0 ? "\n    " : ",\n    ") + spaced(j.dump(-1, ' ', false, json::error_handler_t::replace));
  }
  out += level.lights.empty() ? "]\n" : "\n  ]\n";
  out += "}\n";
  return out;
}

Status save_level_json(const std::string& path, const LevelDescription& level) {
  std::string text;
  try {
    text = level_to_json(level);
  } catch (const std::exception& e) {
    return Status::error(ErrorCode::internal_error, path + ": cannot serialise level: " + e.what());
  }
  return write_file_atomic(path, std::as_bytes(std::span<const char>(text.data(), text.size())));
}

}  // namespace modrt::precompute
