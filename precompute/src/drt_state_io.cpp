// SPDX-License-Identifier: MIT
// The DRT build state file (drt_state_io.h) and the check of a state's traced results
// (drt_state.h check_state_rows).
#include "modrt/precompute/drt_state_io.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <memory>
#include <type_traits>
#include <utility>

#include "binary_io.h"  // core's, as the level and DRT operator files
#include "drt_state.h"
#include "modrt/file_io.h"
#include "modrt/precompute/clutter_mesh.h"
#include "sealed_file.h"

namespace modrt::precompute {

namespace drt_detail {
namespace {

std::string check_block_rows(const BlockRows& rows, std::size_t length, const StateBounds& b) {
  for (const auto& [block, row] : rows) {
    if (block >= b.level_blocks)
      return "block " + std::to_string(block) + ", of " + std::to_string(b.level_blocks) + " level blocks";
    if (row.size() != length)
      return "a row of " + std::to_string(row.size()) + " values, not " + std::to_string(length);
  }
  return {};
}

std::string check_samples(const std::vector<std::pair<std::uint32_t, float>>& entries, const StateBounds& b) {
  for (const auto& [sample, weight] : entries)
    if (sample >= b.level_samples)
      return "sample " + std::to_string(sample) + ", of " + std::to_string(b.level_samples) +
             " level samples";
  return {};
}

std::string check_texel_keys(const std::vector<std::pair<std::uint64_t, float>>& entries,
                             const StateBounds& b) {
  for (const auto& [key, weight] : entries) {
    const std::uint32_t object = cc_object(key), texel = cc_slot(key);
    if (object >= b.texels.size())
      return "a texel of object " + std::to_string(object) + ", of " + std::to_string(b.texels.size()) +
             " objects";
    if (texel >= b.texels[object])
      return "texel " + std::to_string(texel) + " of object " + std::to_string(object) + ", which has " +
             std::to_string(b.texels[object]);
  }
  return {};
}

// W entries per entry of the object's c, or none.
std::string check_columns(std::size_t values, std::uint32_t object, std::size_t W, const StateBounds& b) {
  const std::size_t columns = b.columns[object];
  const bool fits =
      b.exact_columns ? values == 0 || values == W * columns : values % W == 0 && values <= W * columns;
  if (fits) return {};
  return "dUc of " + std::to_string(values) + " values for object " + std::to_string(object) + " (" +
         (b.exact_columns ? "" : "at most ") + std::to_string(columns) + " entries of c, " +
         std::to_string(W) + " values each)";
}

std::string check_results(const std::vector<SampleResult>& results, std::size_t W, const StateBounds& b,
                          const char* item) {
  const std::size_t objects = b.texels.size();
  for (std::size_t s = 0; s < results.size(); ++s) {
    const SampleResult& r = results[s];
    std::string why;
    if (r.state != SampleResult::culled && r.state != SampleResult::traced && r.state != SampleResult::inside)
      why = "state " + std::to_string(int(r.state)) + " is not culled, traced or inside";
    else if ((r.state == SampleResult::inside) != (r.inside_of >= 0) || r.inside_of >= std::int64_t(objects))
      why = "inside_of " + std::to_string(r.inside_of) + " with state " + std::to_string(int(r.state)) +
            " and " + std::to_string(objects) + " objects";
    else if (r.state != SampleResult::traced && !r.rows.empty())
      why = "rows, but it was not traced";
    for (std::size_t i = 0; why.empty() && i < r.rows.size(); ++i) {
      const ObjectRows& o = r.rows[i];
      if (o.object >= objects)
        why = "rows of object " + std::to_string(o.object) + ", of " + std::to_string(objects) + " objects";
      else if (i > 0 && o.object <= r.rows[i - 1].object)
        why = "its rows' objects are not ascending";
      else if (std::string w = check_block_rows(o.dUb, W * b.kb, b); !w.empty())
        why = "dUb of object " + std::to_string(o.object) + ": " + w;
      else if (std::string c = check_columns(o.dUc.size(), o.object, W, b); !c.empty())
        why = c;
      else if (std::string m = check_samples(o.samples, b); !m.empty())
        why = "the weights of object " + std::to_string(o.object) + ": " + m;
      else if (std::string t = check_texel_keys(o.texels, b); !t.empty())
        why = "the texels of object " + std::to_string(o.object) + ": " + t;
    }
    if (!why.empty()) return std::string(item) + " " + std::to_string(s) + ": " + why;
  }
  return {};
}

std::string check_texels(const std::vector<TexelResult>& texels, std::uint32_t k, std::size_t W,
                         const StateBounds& b, const char* pass) {
  for (std::size_t i = 0; i < texels.size(); ++i) {
    const TexelResult& t = texels[i];
    std::string why = check_block_rows(t.cb, W * b.kb, b);
    if (why.empty()) why = check_samples(t.samples, b);
    if (why.empty()) why = check_texel_keys(t.texels, b);
    for (const auto& [key, weight] : t.cc) {
      if (!why.empty()) break;
      const std::uint32_t source = cc_object(key), slot = cc_slot(key);
      if (source >= b.texels.size() || source == k)
        why = "Cc from object " + std::to_string(source) + " (" + std::to_string(b.texels.size()) +
              " objects, never the texel's own)";
      else if (slot >= W * b.columns[source])
        why = "Cc entry " + std::to_string(slot) + " of object " + std::to_string(source) + ", which has " +
              std::to_string(W * b.columns[source]);
    }
    if (!why.empty())
      return std::string(pass) + " object " + std::to_string(k) + " texel " + std::to_string(i) + ": " + why;
  }
  return {};
}

}  // namespace

std::string check_state_rows(const StateAccess::Impl& st, const StateBounds& b) {
  const std::size_t objects = st.objects.size();
  if (b.texels.size() != objects || b.columns.size() != objects)
    return "bounds for " + std::to_string(b.texels.size()) + " objects, the state has " +
           std::to_string(objects);
  if (std::string why = check_results(st.samples, 1, b, "scene pass sample"); !why.empty()) return why;
  if (std::string why = check_results(st.vector_samples, kOhlshCount, b, "vector scene pass sample");
      !why.empty())
    return why;
  if (std::string why = check_results(st.probes, kSh9Count, b, "probe pass probe"); !why.empty()) return why;
  for (std::size_t k = 0; k < st.texels.size(); ++k)
    if (std::string why = check_texels(st.texels[k], std::uint32_t(k), 1, b, "clutter pass"); !why.empty())
      return why;
  for (std::size_t k = 0; k < st.vector_texels.size(); ++k)
    if (std::string why =
            check_texels(st.vector_texels[k], std::uint32_t(k), kOhlshCount, b, "vector clutter pass");
        !why.empty())
      return why;
  return {};
}

}  // namespace drt_detail

namespace {

using binary::Reader;
using binary::Writer;
using drt_detail::BlockRows;
using drt_detail::ObjectRows;
using drt_detail::SampleResult;
using drt_detail::StateAccess;
using drt_detail::StateBounds;
using drt_detail::TexelResult;
using Impl = StateAccess::Impl;

static_assert(kDrtStateFileHeaderBytes == binary::kSealedHeaderBytes);

// Fields: level samples, level blocks, kb, objects, probes per block, scene key low and high.
binary::SealedFormat state_file_format() {
  binary::SealedFormat f;
  f.magic = kDrtStateFileMagic;
  f.kind = "modrt DRT build state file";
  f.writer = "DRT build state";
  f.version = kDrtStateFileVersion;
  f.fields = 7;
  f.max_file_bytes = kMaxDrtStateFileBytes;
  f.rebuild = "delete it; the next full DRT build writes it again";
  return f;
}

enum SettingFlag : std::uint32_t {
  kInpaint = 1,
  kCull = 2,
  kVector = 4,
  kProbes = 8,
  kSampleGather = 16,
  kGather = 32,
  kAllSettingFlags = 63
};

// The bounds a file's results are checked against: the header's level sizes, the objects'
// texel counts and their entries of c (exact without a lighting prior; with one, its most
// modes: min(clutter_prior_modes, texels, prior lights), at least 1).
StateBounds file_bounds(const Impl& st) {
  StateBounds b{st.kb, st.level_blocks, st.level_samples, {}, {}, st.settings.clutter_prior_modes == 0};
  const std::uint64_t g = std::uint64_t(std::max(1, st.settings.clutter_prior_grid));
  for (const ClutterObject& o : st.objects) {
    const std::uint32_t m = std::uint32_t(clutter_texel_count(o));
    b.texels.push_back(m);
    b.columns.push_back(b.exact_columns ? std::uint32_t(clutter_face_count(o))
                                        : std::uint32_t(std::max<std::uint64_t>(
                                              1, std::min({std::uint64_t(st.settings.clutter_prior_modes),
                                                           std::uint64_t(m), g * g * g}))));
  }
  return b;
}

// --- writing ---

// Little-endian stores and loads of runs of values (the rows and weight lists, most of the
// file), independent of the host byte order.
template <class U>
void store_le(std::byte* p, U v) {
  for (std::size_t i = 0; i < sizeof(U); ++i) p[i] = std::byte((v >> (8 * i)) & 0xFFu);
}
template <class U>
U load_le(const std::byte* p) {
  U v = 0;
  for (std::size_t i = 0; i < sizeof(U); ++i) v |= std::to_integer<U>(p[i]) << (8 * i);
  return v;
}
// A pair list's key or weight as the unsigned integer of its size (weights by bit pattern).
template <class T>
auto bits_of(T v) {
  if constexpr (std::is_same_v<T, float>) {
    return std::bit_cast<std::uint32_t>(v);
  } else if constexpr (std::is_same_v<T, double>) {
    return std::bit_cast<std::uint64_t>(v);
  } else {
    return v;
  }
}
template <class T, class U>
T from_bits(U v) {
  if constexpr (std::is_floating_point_v<T>) {
    return std::bit_cast<T>(v);
  } else {
    return v;
  }
}
template <class T>
using BitsOf = decltype(bits_of(T{}));

// binary::Writer that remembers the part of the file where it first wrote NaN or Inf; or,
// with count_only, counts the bytes it would write (so that the buffer is allocated once).
struct StateWriter {
  Writer w;
  bool count_only = false;
  std::uint64_t size = 0;
  const char* part = "";
  const char* non_finite = nullptr;
  void u32(std::uint32_t v) {
    if (count_only) {
      size += 4;
    } else {
      w.u32(v);
    }
  }
  void i32(std::int32_t v) { u32(std::uint32_t(v)); }
  void u64(std::uint64_t v) {
    if (count_only) {
      size += 8;
    } else {
      w.u64(v);
    }
  }
  void finite(double v) {
    if (!std::isfinite(v) && !non_finite) non_finite = part;
  }
  void f64(double v) {
    finite(v);
    u64(std::bit_cast<std::uint64_t>(v));
  }
  void vec(const glm::dvec3& v) {
    for (int a = 0; a < 3; ++a) f64(v[a]);
  }
  // n bytes written by fill(first byte).
  template <class Fill>
  void run(std::size_t n, Fill&& fill) {
    if (count_only) {
      size += n;
      return;
    }
    const std::size_t at = w.bytes.size();
    w.bytes.resize(at + n);
    fill(w.bytes.data() + at);
  }
  // The values alone (their count is known to the reader).
  void f64s(std::span<const double> v) {
    for (double x : v) finite(x);
    run(8 * v.size(), [&](std::byte* p) {
      for (std::size_t i = 0; i < v.size(); ++i) store_le(p + 8 * i, std::bit_cast<std::uint64_t>(v[i]));
    });
  }
  // u32 n, then n (key, weight).
  template <class Key, class Weight>
  void pairs(const std::vector<std::pair<Key, Weight>>& entries) {
    u32(std::uint32_t(entries.size()));
    for (const auto& e : entries) finite(double(e.second));
    run(entries.size() * (sizeof(Key) + sizeof(Weight)), [&](std::byte* p) {
      for (const auto& [key, weight] : entries) {
        store_le(p, bits_of(key));
        store_le(p + sizeof(Key), bits_of(weight));
        p += sizeof(Key) + sizeof(Weight);
      }
    });
  }
};

void put_block_rows(StateWriter& w, const BlockRows& rows) {
  w.u32(std::uint32_t(rows.size()));
  for (const auto& [block, row] : rows) {
    w.u32(block);
    w.f64s(row);
  }
}

void put_results(StateWriter& w, const std::vector<SampleResult>& results) {
  w.u32(std::uint32_t(results.size()));
  for (const SampleResult& r : results) {
    w.u32(std::uint32_t(r.state));
    w.i32(r.inside_of);
    w.u32(std::uint32_t(r.rows.size()));
    for (const ObjectRows& o : r.rows) {
      w.u32(o.object);
      put_block_rows(w, o.dUb);
      w.u32(std::uint32_t(o.dUc.size()));
      w.f64s(o.dUc);
      w.pairs(o.samples);
      w.pairs(o.texels);
    }
  }
}

void put_texels(StateWriter& w, const std::vector<TexelResult>& texels) {
  w.u32(std::uint32_t(texels.size()));
  for (const TexelResult& t : texels) {
    put_block_rows(w, t.cb);
    w.pairs(t.samples);
    w.pairs(t.texels);
    w.pairs(t.cc);
  }
}

// --- reading ---

class StateReader {
 public:
  StateReader(Reader& in) : in_(in) {}
  Reader& in() { return in_; }
  // The first field holding NaN or Inf, or "".
  const std::string& non_finite() const { return non_finite_; }

  void finite(double v, const std::string& field) {
    if (!std::isfinite(v) && non_finite_.empty()) non_finite_ = field;
  }
  double f64(const std::string& field) {
    const double v = in_.f64(field);
    if (in_.ok()) finite(v, field);
    return v;
  }
  glm::dvec3 vec(const std::string& field) {
    glm::dvec3 v;
    for (int a = 0; a < 3; ++a) v[a] = f64(field);
    return v;
  }
  // A list's count, refused when `item_bytes` each do not fit in what is left.
  std::uint32_t count(const std::string& field, std::uint64_t item_bytes) {
    const std::uint32_t n = in_.u32(field + " count");
    return in_.fits(field, n, item_bytes) ? n : 0;
  }
  // out.size() doubles.
  void f64s(const std::string& field, std::vector<double>& out) {
    const std::span<const std::byte> b = in_.take(field, 8 * out.size());
    if (b.size() != 8 * out.size()) return;  // the reader failed
    for (std::size_t i = 0; i < out.size(); ++i) {
      out[i] = std::bit_cast<double>(load_le<std::uint64_t>(b.data() + 8 * i));
      finite(out[i], field);
    }
  }
  // u32 n, then n (key, weight).
  template <class Key, class Weight>
  std::vector<std::pair<Key, Weight>> pairs(const std::string& field) {
    constexpr std::size_t item = sizeof(Key) + sizeof(Weight);
    std::vector<std::pair<Key, Weight>> v(count(field, item));
    const std::span<const std::byte> b = in_.take(field, item * v.size());
    if (b.size() != item * v.size()) return {};  // the reader failed
    const std::byte* p = b.data();
    for (auto& [key, weight] : v) {
      key = from_bits<Key>(load_le<BitsOf<Key>>(p));
      weight = from_bits<Weight>(load_le<BitsOf<Weight>>(p + sizeof(Key)));
      finite(double(weight), field);
      p += item;
    }
    return v;
  }

  BlockRows block_rows(const std::string& field, std::size_t length) {
    BlockRows rows;
    const std::uint32_t n = count(field, 4 + 8 * std::uint64_t(length));
    for (std::uint32_t i = 0; i < n && in_.ok(); ++i) {
      const std::uint32_t block = in_.u32(field);
      if (!rows.empty() && block <= rows.rbegin()->first) {
        in_.fail(field, "blocks not ascending");
        break;
      }
      std::vector<double>& row = rows[block];
      row.resize(length);
      f64s(field, row);
    }
    return rows;
  }
  std::vector<double> doubles(const std::string& field) {
    std::vector<double> v(count(field, 8));
    f64s(field, v);
    return v;
  }

  // A pass's sample results: `expected` of them (W values per kb in a row).
  std::vector<SampleResult> results(const std::string& pass, std::uint64_t expected, std::size_t row_length) {
    const std::uint32_t n = in_.u32(pass + " count");
    if (!in_.ok()) return {};
    if (n != expected) {
      in_.fail(pass, std::to_string(n) + " results, not " + std::to_string(expected));
      return {};
    }
    // State, inside_of and the row count: 12 bytes at least.
    if (!in_.fits(pass, n, 12)) return {};
    std::vector<SampleResult> out(n);
    for (std::uint32_t s = 0; s < n && in_.ok(); ++s) {
      SampleResult& r = out[s];
      const std::string at = pass + " " + std::to_string(s);
      const std::uint32_t state = in_.u32(at + " state");
      if (in_.ok() && state > SampleResult::inside) {
        in_.fail(at, "state " + std::to_string(state) + " is not 0 (culled), 1 (traced) or 2 (inside)");
        break;
      }
      r.state = SampleResult::State(state);
      r.inside_of = in_.i32(at + " inside_of");
      // Object, then four lists' counts.
      r.rows.resize(count(at + " rows", 20));
      for (ObjectRows& o : r.rows) {
        o.object = in_.u32(at + " object");
        const std::string of = at + " object " + std::to_string(o.object);
        o.dUb = block_rows(of + " dUb", row_length);
        o.dUc = doubles(of + " dUc");
        o.samples = pairs<std::uint32_t, float>(of + " sample weights");
        o.texels = pairs<std::uint64_t, float>(of + " texel weights");
        if (!in_.ok()) break;
      }
    }
    return out;
  }

  std::vector<TexelResult> texels(const std::string& at, std::uint64_t expected, std::size_t row_length) {
    const std::uint32_t n = in_.u32(at + " count");
    if (!in_.ok()) return {};
    if (n != expected) {
      in_.fail(at,
               std::to_string(n) + " texel results, the object has " + std::to_string(expected) + " texels");
      return {};
    }
    if (!in_.fits(at, n, 16)) return {};  // four lists' counts
    std::vector<TexelResult> out(n);
    for (std::uint32_t i = 0; i < n && in_.ok(); ++i) {
      TexelResult& t = out[i];
      const std::string of = at + " texel " + std::to_string(i);
      t.cb = block_rows(of + " Cb rows", row_length);
      t.samples = pairs<std::uint32_t, float>(of + " sample weights");
      t.texels = pairs<std::uint64_t, float>(of + " texel weights");
      t.cc = pairs<std::uint64_t, double>(of + " Cc");
    }
    return out;
  }

 private:
  Reader& in_;
  std::string non_finite_;
};

// One object as written by serialize (drt_state_io.h), checked as validate_clutter checks it
// (the block against the header's level blocks, res bounded); a mesh's atlas made again.
Result<ClutterObject> read_object(StateReader& r, std::uint32_t level_blocks, const std::string& what,
                                  std::uint32_t k) {
  Reader& in = r.in();
  const std::string at = "object " + std::to_string(k);
  ClutterObject o;
  const std::uint32_t kind = in.u32(at + " kind");
  const std::uint32_t block = in.u32(at + " block");
  o.box.center = r.vec(at + " box centre");
  o.box.half_extent = r.vec(at + " box half extent");
  for (int c = 0; c < 3; ++c) o.box.rotation[c] = r.vec(at + " box rotation");
  const std::uint32_t faces = in.u32(at + " faces");
  o.albedo = r.vec(at + " albedo");
  const std::uint32_t res = in.u32(at + " res");
  ClutterMesh mesh;
  if (in.ok() && kind == std::uint32_t(ClutterKind::mesh)) {
    mesh.positions.resize(r.count(at + " mesh positions", 24));
    for (glm::dvec3& p : mesh.positions) p = r.vec(at + " mesh positions");
    mesh.uvs.resize(r.count(at + " mesh uvs", 16));
    for (glm::dvec2& uv : mesh.uvs) uv.x = r.f64(at + " mesh uvs"), uv.y = r.f64(at + " mesh uvs");
    mesh.indices.resize(r.count(at + " mesh indices", 4));
    for (std::uint32_t& i : mesh.indices) i = in.u32(at + " mesh indices");
  }
  if (!in.ok()) return in.status();
  auto bad = [&](const std::string& problem) {
    return Status::error(ErrorCode::format_error, what + ": " + at + ": " + problem);
  };
  if (!r.non_finite().empty())
    return Status::error(ErrorCode::non_finite, what + ": " + r.non_finite() + " has NaN or Inf");
  if (kind > std::uint32_t(ClutterKind::mesh))
    return bad("kind " + std::to_string(kind) + " is not 0 (box) or 1 (mesh)");
  if (block >= level_blocks)
    return bad("block " + std::to_string(block) + ", of " + std::to_string(level_blocks) + " level blocks");
  if ((faces & ~std::uint32_t(kAllFaces)) != 0 || faces == 0)
    return bad("faces " + std::to_string(faces) + " must name 1 to 6 faces");
  if (res < 1 || res > kMaxClutterCellRes)
    return bad("res " + std::to_string(res) + " is not in [1, " + std::to_string(kMaxClutterCellRes) + "]");
  for (int a = 0; a < 3; ++a) {
    if (!(o.box.half_extent[a] > 0.0)) return bad("box half extents must be positive");
    if (!(o.albedo[a] >= 0.0 && o.albedo[a] <= 1.0)) return bad("albedo outside [0, 1]");
  }
  const glm::dmat3 RtR = glm::transpose(o.box.rotation) * o.box.rotation;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (!(std::abs(RtR[j][i] - (i == j ? 1.0 : 0.0)) <= 1e-6))
        return bad("box rotation is not orthonormal");
  o.kind = ClutterKind(kind);
  o.block = int(block);
  o.faces = FaceMask(faces);
  o.res = int(res);
  if (o.kind == ClutterKind::mesh) {
    Result<ClutterObject> made = make_mesh_clutter(std::move(mesh), o.block, o.albedo, o.res, at + " mesh");
    if (!made.ok()) return bad(made.status().message());
    // The box and faces as the build saw them (make_mesh_clutter's bounds unless changed since).
    made->box = o.box;
    made->faces = o.faces;
    return std::move(made).value();
  }
  return o;
}

void put_body(StateWriter& w, const Impl& st) {
  const DrtBuildSettings& s = st.settings;
  w.part = "settings";
  w.u32(std::uint32_t(s.rays));
  w.u32(std::uint32_t(s.max_clutter_rays));
  w.u32(std::uint32_t(s.cb_modes));
  w.u32(std::uint32_t(s.clutter_prior_modes));
  w.u32(std::uint32_t(s.clutter_prior_grid));
  w.u32((s.inpaint ? kInpaint : 0u) | (s.cull ? kCull : 0u) | (s.vector ? kVector : 0u) |
        (s.probes ? kProbes : 0u) | (s.sample_gather ? kSampleGather : 0u) | (s.gather ? kGather : 0u));
  w.f64(s.drop_tolerance);
  w.u64(s.seed);
  w.part = "the objects";
  for (const ClutterObject& o : st.objects) {
    w.u32(std::uint32_t(o.kind));
    w.u32(std::uint32_t(o.block));
    w.vec(o.box.center);
    w.vec(o.box.half_extent);
    for (int c = 0; c < 3; ++c) w.vec(o.box.rotation[c]);
    w.u32(o.faces);
    w.vec(o.albedo);
    w.u32(std::uint32_t(o.res));
    if (o.kind == ClutterKind::mesh) {
      const ClutterMesh& m = o.mesh->mesh;
      w.u32(std::uint32_t(m.positions.size()));
      for (const glm::dvec3& p : m.positions) w.vec(p);
      w.u32(std::uint32_t(m.uvs.size()));
      for (const glm::dvec2& uv : m.uvs) w.f64(uv.x), w.f64(uv.y);
      w.u32(std::uint32_t(m.indices.size()));
      for (std::uint32_t i : m.indices) w.u32(i);
    }
  }
  w.part = "the scene pass";
  put_results(w, st.samples);
  w.part = "the vector scene pass";
  put_results(w, st.vector_samples);
  w.part = "the probe pass";
  put_results(w, st.probes);
  w.part = "the clutter pass";
  for (const std::vector<TexelResult>& t : st.texels) put_texels(w, t);
  w.part = "the vector clutter pass";
  w.u32(st.vector_texels.empty() ? 0u : 1u);
  for (const std::vector<TexelResult>& t : st.vector_texels) put_texels(w, t);
}

}  // namespace

Result<std::vector<std::byte>> serialize_drt_build_state(const DrtBuildState& state,
                                                         std::uint64_t scene_key) {
  const Impl* st = StateAccess::get(state);
  if (!st) return Status::error(ErrorCode::invalid_argument, "DRT build state: empty (no build filled it)");
  for (std::size_t k = 0; k < st->objects.size(); ++k) {
    const ClutterObject& o = st->objects[k];
    if (o.kind == ClutterKind::mesh && (!o.mesh || o.mesh->atlas.res != o.res))
      return Status::error(ErrorCode::invalid_argument,
                           "DRT build state: object " + std::to_string(k) +
                               ": a mesh without data or with an atlas of another res");
  }
  // What the reader would refuse is not written.
  if (const std::string why = drt_detail::check_state_rows(*st, file_bounds(*st)); !why.empty())
    return Status::error(ErrorCode::invalid_argument, "DRT build state: " + why);
  StateWriter counter;
  counter.count_only = true;
  put_body(counter, *st);
  if (counter.size > kMaxDrtStateFileBytes - kDrtStateFileHeaderBytes)
    return Status::error(ErrorCode::resource_limit,
                         "DRT build state: the file would be " +
                             std::to_string(counter.size + kDrtStateFileHeaderBytes) +
                             " bytes, more than the limit of " + std::to_string(kMaxDrtStateFileBytes));
  StateWriter w;
  w.w.bytes.reserve(std::size_t(counter.size));
  put_body(w, *st);
  // NaN or Inf would make NaN operators: refused, as the operator file refuses them.
  if (w.non_finite)
    return Status::error(ErrorCode::non_finite,
                         std::string("DRT build state: ") + w.non_finite + " has NaN or Inf");
  return binary::seal(state_file_format(),
                      {st->level_samples, st->level_blocks, st->kb, std::uint32_t(st->objects.size()),
                       st->probes_per_block, std::uint32_t(scene_key), std::uint32_t(scene_key >> 32), 0},
                      w.w.bytes);
}

Status save_drt_build_state(const std::string& path, const DrtBuildState& state, std::uint64_t scene_key) {
  Result<std::vector<std::byte>> bytes = serialize_drt_build_state(state, scene_key);
  if (!bytes.ok()) return Status::error(bytes.status().code(), path + ": " + bytes.status().message());
  return write_file_atomic(path, bytes.value());
}

Result<LoadedDrtBuildState> parse_drt_build_state(std::span<const std::byte> bytes, const std::string& what) {
  binary::SealedFields header{};
  const Result<std::span<const std::byte>> sealed =
      binary::open_sealed(state_file_format(), bytes, what, header);
  if (!sealed.ok()) return sealed.status();
  auto st = std::make_unique<Impl>();
  st->level_samples = header[0];
  st->level_blocks = header[1];
  st->kb = header[2];
  const std::uint32_t objects = header[3];
  st->probes_per_block = header[4];
  LoadedDrtBuildState out;
  out.scene_key = std::uint64_t(header[5]) | (std::uint64_t(header[6]) << 32);
  auto bad = [&](const std::string& problem) {
    return Status::error(ErrorCode::format_error, what + ": " + problem);
  };
  if (st->kb == 0 || st->kb > binary::kMaxMatrixDimension)
    return bad("kb " + std::to_string(st->kb) + " is out of range");

  Reader in(sealed.value(), what);
  StateReader r(in);
  DrtBuildSettings& s = st->settings;
  s.rays = int(in.u32("settings rays"));
  s.max_clutter_rays = int(in.u32("settings max_clutter_rays"));
  s.cb_modes = int(in.u32("settings cb_modes"));
  s.clutter_prior_modes = int(in.u32("settings clutter_prior_modes"));
  s.clutter_prior_grid = int(in.u32("settings clutter_prior_grid"));
  const std::uint32_t flags = in.u32("settings flags");
  s.drop_tolerance = r.f64("settings drop_tolerance");
  s.seed = in.u64("settings seed");
  if (!in.ok()) return in.status();
  if ((flags & ~std::uint32_t(kAllSettingFlags)) != 0)
    return bad("settings flags " + std::to_string(flags) + " has unknown bits");
  s.inpaint = flags & kInpaint;
  s.cull = flags & kCull;
  s.vector = flags & kVector;
  s.probes = flags & kProbes;
  s.sample_gather = flags & kSampleGather;
  s.gather = flags & kGather;
  if (Status v = validate_drt_build_settings(s); !v.ok()) return bad(v.message());
  if ((st->probes_per_block != 0) != s.probes)
    return bad("probes per block " + std::to_string(st->probes_per_block) +
               (s.probes ? " with" : " without") + " the probe pass");

  // An object is at least 19 fields of 4 or 8 bytes.
  if (in.fits("objects", objects, 4 * 4 + 8 * 15)) st->objects.reserve(objects);
  for (std::uint32_t k = 0; k < objects && in.ok(); ++k) {
    Result<ClutterObject> o = read_object(r, st->level_blocks, what, k);
    if (!o.ok()) return o.status();
    st->objects.push_back(std::move(o).value());
  }
  if (!in.ok()) return in.status();
  const bool any = objects > 0;
  st->samples = r.results("scene pass sample", any ? st->level_samples : 0, st->kb);
  st->vector_samples = r.results("vector scene pass sample", any && s.vector ? st->level_samples : 0,
                                 kOhlshCount * std::size_t(st->kb));
  st->probes = r.results("probe pass probe", any ? std::uint64_t(st->level_blocks) * st->probes_per_block : 0,
                         kSh9Count * std::size_t(st->kb));
  for (std::uint32_t k = 0; k < objects && in.ok(); ++k)
    st->texels.push_back(r.texels("clutter pass object " + std::to_string(k),
                                  std::uint64_t(clutter_texel_count(st->objects[k])), st->kb));
  const std::uint32_t vector_texels = in.u32("vector clutter pass present");
  if (in.ok() && vector_texels != ((any && s.vector) ? 1u : 0u))
    in.fail("vector clutter pass present",
            std::to_string(vector_texels) + (s.vector ? " with" : " without") + " the vector pass");
  if (vector_texels == 1)
    for (std::uint32_t k = 0; k < objects && in.ok(); ++k)
      st->vector_texels.push_back(r.texels("vector clutter pass object " + std::to_string(k),
                                           std::uint64_t(clutter_texel_count(st->objects[k])),
                                           kOhlshCount * std::size_t(st->kb)));
  if (!in.ok()) return in.status();
  if (in.left() != 0) return bad(std::to_string(in.left()) + " trailing bytes after the last pass");
  if (!r.non_finite().empty())
    return Status::error(ErrorCode::non_finite, what + ": " + r.non_finite() + " has NaN or Inf");
  if (const std::string why = drt_detail::check_state_rows(*st, file_bounds(*st)); !why.empty())
    return bad(why);
  for (const ClutterObject& o : st->objects) st->geometry.push_back(clutter_texel_geometry(o));
  StateAccess::set(out.state, std::move(st));
  return out;
}

Result<LoadedDrtBuildState> load_drt_build_state(const std::string& path) {
  Result<std::vector<std::byte>> bytes = read_file(path, kMaxDrtStateFileBytes);
  if (!bytes.ok()) return bytes.status();
  return parse_drt_build_state(bytes.value(), path);
}

}  // namespace modrt::precompute
