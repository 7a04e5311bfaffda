// SPDX-License-Identifier: MIT
#include "gles_drt.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <tuple>
#include <utility>

#include "gl_objects.h"
#include "modrt/feedback_policy.h"
#include "modrt/reference_runtime.h"

namespace modrt::gles {

// Shader sources, generated from gles/shaders/*.glsl by cmake/EmbedShaders.cmake.
extern const char* const kCommon;
extern const char* const kFullscreenVert;
extern const char* const kDrtCFrag;
extern const char* const kDrtFeedbackFrag;
extern const char* const kDrtDeltaFrag;
extern const char* const kDrtVcFrag;
extern const char* const kDrtClutterFrag;
extern const char* const kDrtGather;
extern const char* const kDrtLightFrag;

namespace {

std::size_t quads(std::size_t n) { return (n + 3) / 4; }

Status wrong_size(const char* what, std::size_t got, std::size_t expected) {
  return Status::error(ErrorCode::invalid_argument, std::string("gles drt: ") + what + ": has " +
                                                        std::to_string(got) + " floats, expected " +
                                                        std::to_string(expected));
}

// Clutter atlas rows of an object whose texels are not res x res faces: rows this wide.
constexpr int kRowTexels = 256;

}  // namespace

GlesDrt::~GlesDrt() {
  for (GLuint p : programs_) gl_.glDeleteProgram(p);
  if (!framebuffers_.empty()) gl_.glDeleteFramebuffers(GLsizei(framebuffers_.size()), framebuffers_.data());
  if (!textures_.empty()) gl_.glDeleteTextures(GLsizei(textures_.size()), textures_.data());
}

std::array<int, 2> GlesDrt::clutter_texel(std::size_t object, std::uint32_t t) const {
  const Placement& p = placement_[object];
  if (p.tiles) {
    const std::uint32_t r = std::uint32_t(p.res), face = t / (r * r), rest = t % (r * r);
    return {int(face * r + rest % r), p.y + int(rest / r)};
  }
  return {int(t % std::uint32_t(p.width)), p.y + int(t / std::uint32_t(p.width))};
}

Result<std::unique_ptr<GlesDrt>> GlesDrt::create(const platform::GlFunctions& gl, const Level& level,
                                                 const DrtOperators& drt, const GlesDrtSetup& setup) {
  std::unique_ptr<GlesDrt> d(new GlesDrt(gl));
  d->drt_ = &drt;
  d->sizes_ = drt_buffer_sizes(drt);
  d->output_bits_ = setup.output_bits;
  const std::size_t kb = level.kb, G = quads(kb), samples = level.sample_count;

  // ---- operators and tables (layouts: gles/README.md, "DRT") ----
  std::vector<float> td_c, vc, uc;
  std::vector<std::int32_t> face_info, mode_info, cb_blocks;
  std::vector<std::array<std::int32_t, 4>> texel_values;  // per clutter texel: the map's value
  std::vector<std::array<std::int32_t, 4>> texel_cc;      // per clutter texel: the Cc map's value
  std::vector<float> cc;                                  // Cc rows, four columns per texel
  std::vector<std::int32_t> cc_faces;                     // per Cc column: its c index (face)
  std::vector<std::size_t> object_face0(1, 0);
  for (const DrtObjectOperators& o : drt.objects) object_face0.push_back(object_face0.back() + o.face_count);
  // Row `row` of A (its first `cols` values) appended to `out`, four per texel (the matrix
  // rows of Td_c, Uc, Cc and their vector twins); returns the row's first texel.
  auto add_row = [](const Matrix& A, std::uint32_t row, std::size_t cols, std::vector<float>& out) {
    const std::size_t base = out.size() / 4;
    out.resize(out.size() + 4 * quads(cols), 0.0f);
    for (std::size_t k = 0; k < cols; ++k) out[4 * base + k] = A(row, std::uint32_t(k));
    return base;
  };
  // DRT §4.3: an object's Vc (or Vc_vec) rows, kb values per block at G texels a block, with
  // one mode-table entry each (first Vc texel, first block-list entry, blocks).
  auto add_modes = [&](const Matrix& V, const std::vector<std::uint32_t>& blocks, std::vector<float>& v_out,
                       std::vector<std::int32_t>& mode_out, std::vector<std::int32_t>& blocks_out) {
    const std::size_t nb = blocks.size(), b0 = blocks_out.size() / 4;
    for (std::uint32_t blk : blocks) blocks_out.insert(blocks_out.end(), {std::int32_t(blk), 0, 0, 0});
    for (std::uint32_t q = 0; q < V.rows; ++q) {
      const std::size_t base = v_out.size() / 4;
      v_out.resize(v_out.size() + 4 * nb * G, 0.0f);
      for (std::size_t blk = 0; blk < nb; ++blk)
        for (std::size_t k = 0; k < kb; ++k)
          v_out[4 * (base + blk * G) + k] = V(q, std::uint32_t(blk * kb + k));
      mode_out.insert(mode_out.end(), {std::int32_t(base), std::int32_t(b0), std::int32_t(nb), 0});
    }
  };
  // Clutter-to-clutter light (drt.h, Cc): Cc's (or Cc_vec's) columns are the source objects'
  // c entries; appends each column's index into c, returns the first column's table entry.
  auto add_cc_columns = [&](const std::vector<std::uint32_t>& sources, std::vector<std::int32_t>& out) {
    const std::size_t first = out.size() / 4;
    for (std::uint32_t src : sources)
      for (std::uint32_t k = 0; k < drt.objects[src].face_count; ++k)
        out.insert(out.end(), {std::int32_t(object_face0[src] + k), 0, 0, 0});
    return first;
  };
  std::size_t texel0 = 0, face0 = 0, mode0 = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    const std::size_t m = o.texel_count, f = o.face_count, modes = o.Uc.cols;
    d->texel0_.push_back(texel0);
    for (std::uint32_t r = 0; r < f; ++r) {  // DRT §4.2
      const std::size_t base = add_row(o.Td_c, r, m, td_c);
      face_info.insert(face_info.end(), {std::int32_t(base), std::int32_t(texel0), std::int32_t(m), 0});
    }
    add_modes(o.Vc, o.Cb_blocks, vc, mode_info, cb_blocks);
    for (std::uint32_t t = 0; t < m; ++t) {
      const std::size_t base = add_row(o.Uc, t, modes, uc);
      texel_values.push_back(
          {std::int32_t(texel0 + t), std::int32_t(base), std::int32_t(mode0), std::int32_t(modes)});
    }
    const std::size_t cc_cols = o.Cc.empty() ? 0 : o.Cc.cols,
                      cc_face0 = add_cc_columns(o.Cc_objects, cc_faces);
    for (std::uint32_t t = 0; t < m; ++t) {
      const std::size_t base = add_row(o.Cc, t, cc_cols, cc);
      texel_cc.push_back({std::int32_t(base), std::int32_t(cc_cols), std::int32_t(cc_face0), 0});
    }
    texel0 += m;
    face0 += f;
    mode0 += modes;
  }
  d->faces_ = int(face0);
  d->modes_ = int(mode0);

  // Vector clutter (DRT §5, C_b vector): the same tables for Uc_vec / Vc_vec / Cc_vec, with
  // row r = 4 t + i of object i's texels at linear index 4 (texel0 + t) + i of its target.
  std::vector<float> vc_vec, uc_vec, cc_vec;
  std::vector<std::int32_t> mode_info_vec, cb_blocks_vec, cc_faces_vec, vec_map, vec_cc_map;
  for (const DrtObjectOperators& o : drt.objects) d->has_vector_ |= !o.Uc_vec.empty() || !o.Cc_vec.empty();
  std::size_t mode0_vec = 0;
  const std::size_t vec_rows = 4 * d->sizes_.clutter_texels;
  if (d->has_vector_) {
    const std::size_t map_texels = std::size_t(linear_rows(vec_rows)) * std::size_t(kLinearWidth);
    vec_map.assign(4 * map_texels, -1);
    vec_cc_map.assign(4 * map_texels, 0);
    for (std::size_t i = 0; i < drt.objects.size(); ++i) {
      const DrtObjectOperators& o = drt.objects[i];
      const std::size_t rows = 4 * std::size_t(o.texel_count), modes = o.Uc_vec.cols;
      add_modes(o.Vc_vec, o.Cb_vec_blocks, vc_vec, mode_info_vec, cb_blocks_vec);
      const std::size_t cc_cols = o.Cc_vec.empty() ? 0 : o.Cc_vec.cols,
                        cc_face0 = add_cc_columns(o.Cc_vec_objects, cc_faces_vec);
      for (std::uint32_t r = 0; r < rows; ++r) {
        const std::size_t at = 4 * (4 * d->texel0_[i] + r);
        const std::size_t ub = add_row(o.Uc_vec, r, modes, uc_vec),
                          cb = add_row(o.Cc_vec, r, cc_cols, cc_vec);
        const std::int32_t map[4] = {std::int32_t(4 * d->texel0_[i] + r), std::int32_t(ub),
                                     std::int32_t(mode0_vec), std::int32_t(modes)};
        const std::int32_t cmap[4] = {std::int32_t(cb), std::int32_t(cc_cols), std::int32_t(cc_face0), 0};
        std::copy(map, map + 4, vec_map.begin() + std::ptrdiff_t(at));
        std::copy(cmap, cmap + 4, vec_cc_map.begin() + std::ptrdiff_t(at));
      }
      mode0_vec += modes;
    }
  }

  // The real-radiance gather (drt.h, DrtObjectOperators::Gs ... Ht): each row packed as its
  // x_s entries (Gs, Hs) followed by its x_t entries (Gt, Ht), (column, weight bits) each, and
  // described by (first entry, x_s entries, x_t entries, 2): per clutter texel its Gs / Gt row
  // (empty for an object without the gather), per H_sample row a delta entry of its sample.
  struct DeltaEntry {
    std::uint32_t item;
    std::array<std::int32_t, 4> value;
  };
  d->gather_ = drt.has_gather();
  std::vector<std::uint32_t> gather;        // 2 per entry
  std::vector<std::int32_t> gather_texels;  // 4 per clutter texel
  std::vector<DeltaEntry> gather_rows;      // the scalar delta's gather entries
  if (d->gather_) {
    std::size_t entries = 0;
    for (const DrtObjectOperators& o : drt.objects)
      entries += o.Gs.index.size() + o.Gt.index.size() + o.Hs.index.size() + o.Ht.index.size();
    gather.reserve(2 * std::max<std::size_t>(entries, 1));
    auto pack_gather = [&](const DrtSparseRows& xs_part, const DrtSparseRows& xt_part, std::size_t row) {
      const std::size_t first = gather.size() / 2;
      auto put = [&](const DrtSparseRows& g) {
        if (g.empty()) return std::int32_t(0);
        for (std::uint32_t e = g.start[row]; e < g.start[row + 1]; ++e)
          gather.insert(gather.end(), {g.index[e], std::bit_cast<std::uint32_t>(g.weight[e])});
        return std::int32_t(g.start[row + 1] - g.start[row]);
      };
      const std::int32_t from_s = put(xs_part), from_t = put(xt_part);
      return std::array<std::int32_t, 4>{std::int32_t(first), from_s, from_t, 2};
    };
    gather_texels.reserve(4 * std::max<std::size_t>(d->sizes_.clutter_texels, 1));
    for (const DrtObjectOperators& o : drt.objects) {
      for (std::uint32_t t = 0; t < o.texel_count; ++t) {
        const std::array<std::int32_t, 4> row = pack_gather(o.Gs, o.Gt, t);
        gather_texels.insert(gather_texels.end(), row.begin(), row.end());
      }
      for (std::size_t r = 0; r < o.H_sample.size(); ++r)
        gather_rows.push_back({o.H_sample[r], pack_gather(o.Hs, o.Ht, r)});
    }
    if (gather.empty()) gather.assign(2, 0u);
  }

  // Delta operators (DRT §4.1-4.2, §5): per item (level sample or probe) `rows` values from
  // b rows (item, block) and c rows (item). Rows of different objects for the same (item,
  // block) read the same b: they are summed (in double) into one, so that an item under many
  // objects' shadows costs one row per block it sees, not one per object. `extra`: entries
  // added as they are (the gather's rows).
  struct DeltaTables {
    std::vector<float> dub, duc;
    std::vector<std::int32_t> item_entries, entries;
  };
  auto build_delta = [&](std::size_t rows, std::size_t items, auto b_part, auto c_part,
                         const std::vector<DeltaEntry>& extra = {}) {
    using Entry = DeltaEntry;
    std::vector<Entry> entries;
    DeltaTables t;
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::size_t> b_row;  // (item, block) -> row
    std::vector<double> b_sum;
    const std::size_t per_row = rows * kb;
    for (std::size_t i = 0; i < drt.objects.size(); ++i) {
      const DrtObjectOperators& o = drt.objects[i];
      const auto [b_item, b_block, b_op] = b_part(o);
      for (std::size_t r = 0; r < b_item->size(); ++r) {
        auto [it, added] = b_row.try_emplace({(*b_item)[r], (*b_block)[r]}, b_sum.size() / per_row);
        if (added) b_sum.resize(b_sum.size() + per_row, 0.0);
        for (std::size_t j = 0; j < rows; ++j)
          for (std::size_t k = 0; k < kb; ++k)
            b_sum[it->second * per_row + j * kb + k] +=
                double((*b_op)(std::uint32_t(rows * r + j), std::uint32_t(k)));
      }
      const auto [c_item, c_op] = c_part(o);
      const std::size_t f = o.face_count;
      for (std::size_t r = 0; r < c_item->size(); ++r) {
        const std::size_t base = t.duc.size() / 4;
        t.duc.resize(t.duc.size() + 4 * rows * quads(f), 0.0f);
        for (std::size_t j = 0; j < rows; ++j)
          for (std::size_t k = 0; k < f; ++k)
            t.duc[4 * (base + j * quads(f)) + k] = (*c_op)(std::uint32_t(rows * r + j), std::uint32_t(k));
        entries.push_back(
            {(*c_item)[r], {std::int32_t(base), std::int32_t(object_face0[i]), std::int32_t(f), 1}});
      }
    }
    t.dub.assign(4 * G * rows * (b_sum.size() / std::max<std::size_t>(per_row, 1)), 0.0f);
    for (const auto& [key, row] : b_row) {
      for (std::size_t j = 0; j < rows; ++j)
        for (std::size_t k = 0; k < kb; ++k)
          t.dub[4 * G * (rows * row + j) + k] = float(b_sum[row * per_row + j * kb + k]);
      entries.push_back({key.first, {std::int32_t(G * rows * row), std::int32_t(key.second), 0, 0}});
    }
    entries.insert(entries.end(), extra.begin(), extra.end());
    // Entries grouped by item (stable: the objects' order), one range per item.
    std::stable_sort(entries.begin(), entries.end(),
                     [](const Entry& a, const Entry& b) { return a.item < b.item; });
    t.item_entries.assign(4 * std::max<std::size_t>(items, 1), 0);
    for (std::size_t e = 0; e < entries.size(); ++e) {
      std::int32_t* range = &t.item_entries[4 * std::size_t(entries[e].item)];
      if (range[1]++ == 0) range[0] = std::int32_t(e);
      t.entries.insert(t.entries.end(), entries[e].value.begin(), entries[e].value.end());
    }
    return t;
  };
  using Index = const std::vector<std::uint32_t>*;
  DeltaTables scalar = build_delta(
      1, samples,
      [](const DrtObjectOperators& o) {
        return std::tuple<Index, Index, const Matrix*>{&o.dUb_sample, &o.dUb_block, &o.dUb};
      },
      [](const DrtObjectOperators& o) {
        return std::pair<Index, const Matrix*>{&o.dUc_sample, &o.dUc};
      },
      gather_rows);
  bool any_vector = false, any_probes = false;
  for (const DrtObjectOperators& o : drt.objects) {
    any_vector |= !o.dUb_vec.empty() || !o.dUc_vec.empty();
    any_probes |= !o.Udyn.empty() || !o.Udyn_c.empty();
  }
  DeltaTables vector, probes;
  if (setup.vector && any_vector)  // DRT §5, the OHLSH vector irradiance
    vector = build_delta(
        4, samples,
        [](const DrtObjectOperators& o) {
          return std::tuple<Index, Index, const Matrix*>{&o.dUb_vec_sample, &o.dUb_vec_block, &o.dUb_vec};
        },
        [](const DrtObjectOperators& o) {
          return std::pair<Index, const Matrix*>{&o.dUc_vec_sample, &o.dUc_vec};
        });
  // DRT §5, U_dyn; its grid is the runtime's (StagedBackend::set_clutter, check_drt_probe_grid).
  if (setup.probe_count > 0 && any_probes) {
    probes = build_delta(
        9, setup.probe_count,
        [](const DrtObjectOperators& o) {
          return std::tuple<Index, Index, const Matrix*>{&o.Udyn_probe, &o.Udyn_block, &o.Udyn};
        },
        [](const DrtObjectOperators& o) {
          return std::pair<Index, const Matrix*>{&o.Udyn_c_probe, &o.Udyn_c};
        });
  }

  // ---- clutter atlas placement: an object per band of rows ----
  int atlas_w = 1, atlas_h = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    Placement p;
    p.y = atlas_h;
    const std::size_t m = o.texel_count, f = o.face_count;
    const int res = f > 0 ? int(std::lround(std::sqrt(double(m) / double(f)))) : 0;
    p.tiles = res > 0 && std::size_t(res) * std::size_t(res) * f == m;
    p.res = res;
    p.width = p.tiles ? int(f) * res : int(std::clamp<std::size_t>(m, 1, kRowTexels));
    const int height = p.tiles ? res : int((m + std::size_t(p.width) - 1) / std::size_t(p.width));
    atlas_w = std::max(atlas_w, p.width);
    atlas_h += height;
    d->placement_.push_back(p);
  }
  atlas_h = std::max(atlas_h, 1);
  if (atlas_w > setup.max_texture_size || atlas_h > setup.max_texture_size)
    return Status::error(ErrorCode::resource_limit,
                         "gles drt: the clutter atlas (" + std::to_string(atlas_w) + " x " +
                             std::to_string(atlas_h) + ") exceeds GL_MAX_TEXTURE_SIZE " +
                             std::to_string(setup.max_texture_size) + ": too much clutter for one texture");
  std::vector<std::int32_t> texel_map(4 * std::size_t(atlas_w) * std::size_t(atlas_h), -1);
  std::vector<std::int32_t> texel_xy(4 * std::max<std::size_t>(d->sizes_.clutter_texels, 1), 0);
  std::vector<std::int32_t> cc_map(texel_map.size(), 0);
  for (std::size_t i = 0, t = 0; i < drt.objects.size(); ++i)
    for (std::uint32_t k = 0; k < drt.objects[i].texel_count; ++k, ++t) {
      const std::array<int, 2> xy = d->clutter_texel(i, k);
      const std::ptrdiff_t at = 4 * (std::ptrdiff_t(xy[1]) * atlas_w + xy[0]);
      std::copy(texel_values[t].begin(), texel_values[t].end(), texel_map.begin() + at);
      std::copy(texel_cc[t].begin(), texel_cc[t].end(), cc_map.begin() + at);
      texel_xy[4 * t] = xy[0];
      texel_xy[4 * t + 1] = xy[1];
    }

  // ---- textures ----
  Status limit;
  auto linear_texture = [&](const char* name, GLenum format, std::size_t texels) -> GLuint {
    const int rows = linear_rows(texels);
    if (rows > setup.max_texture_size && limit.ok())
      limit = Status::error(ErrorCode::resource_limit,
                            std::string("gles drt: ") + name + " needs " + std::to_string(rows) +
                                " rows, over GL_MAX_TEXTURE_SIZE " + std::to_string(setup.max_texture_size));
    const GLuint tex =
        create_texture(gl, format, kLinearWidth, std::min(rows, std::max(setup.max_texture_size, 1)));
    d->textures_.push_back(tex);
    return tex;
  };
  auto float_table = [&](const char* name, std::vector<float>& data) {
    if (data.empty()) data.assign(4, 0.0f);
    const GLuint tex = linear_texture(name, setup.operator_format, data.size() / 4);
    if (limit.ok()) upload_linear(gl, tex, GL_RGBA, GL_FLOAT, 4, data.data(), data.size() / 4, sizeof(float));
    return tex;
  };
  auto int_table = [&](const char* name, std::vector<std::int32_t>& data) {
    if (data.empty()) data.assign(4, 0);
    const GLuint tex = linear_texture(name, GL_RGBA32I, data.size() / 4);
    if (limit.ok())
      upload_linear(gl, tex, GL_RGBA_INTEGER, GL_INT, 4, data.data(), data.size() / 4, sizeof(std::int32_t));
    return tex;
  };
  d->td_c_ = float_table("Td_c", td_c);
  d->vc_ = float_table("Vc", vc);
  d->uc_ = float_table("Uc", uc);
  d->cc_ = float_table("Cc", cc);
  d->cc_faces_ = int_table("Cc column table", cc_faces);
  d->face_info_ = int_table("clutter face table", face_info);
  d->texel_xy_ = int_table("clutter texel positions", texel_xy);
  if (d->has_vector_) {
    d->vc_vec_ = float_table("Vc_vec", vc_vec);
    d->uc_vec_ = float_table("Uc_vec", uc_vec);
    d->cc_vec_ = float_table("Cc_vec", cc_vec);
    d->mode_info_vec_ = int_table("Cb_vec mode table", mode_info_vec);
    d->cb_blocks_vec_ = int_table("Cb_vec block list", cb_blocks_vec);
    d->cc_faces_vec_ = int_table("Cc_vec column table", cc_faces_vec);
    d->vec_map_ = int_table("vector clutter map", vec_map);
    d->vec_cc_map_ = int_table("vector clutter Cc map", vec_cc_map);
  }
  auto delta_tables = [&](const char* name, DeltaTables& t, DeltaPass& pass) {
    pass.dub = float_table(name, t.dub);
    pass.duc = float_table(name, t.duc);
    pass.item_entries = int_table(name, t.item_entries);
    pass.entries = int_table(name, t.entries);
  };
  delta_tables("dUb / dUc", scalar, d->scalar_);
  if (!vector.entries.empty()) delta_tables("dUb_vec / dUc_vec", vector, d->vector_);
  if (!probes.entries.empty()) delta_tables("Udyn / Udyn_c", probes, d->probes_);
  if (d->gather_) {
    d->gather_entries_ = linear_texture("gather rows", GL_RG32UI, gather.size() / 2);
    if (limit.ok())
      upload_linear(gl, d->gather_entries_, GL_RG_INTEGER, GL_UNSIGNED_INT, 2, gather.data(),
                    gather.size() / 2, sizeof(std::uint32_t));
    d->gather_texels_ = int_table("gather clutter texel table", gather_texels);
  }
  d->mode_info_ = int_table("Cb mode table", mode_info);
  d->cb_blocks_ = int_table("Cb block list", cb_blocks);
  d->clutter_ld_ = linear_texture("clutter_ld", GL_RGB32F, d->sizes_.clutter_texels);
  d->clutter_direct_ = linear_texture("clutter direct light", GL_RGB32F, d->sizes_.clutter_texels);
  d->rho_c_ = linear_texture("clutter albedo", GL_RGB32F, d->sizes_.clutter_texels);
  if (!limit.ok()) return limit;
  d->texel_map_ = create_texture(gl, GL_RGBA32I, atlas_w, atlas_h);
  d->textures_.push_back(d->texel_map_);
  gl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, atlas_w, atlas_h, GL_RGBA_INTEGER, GL_INT, texel_map.data());
  d->cc_map_ = create_texture(gl, GL_RGBA32I, atlas_w, atlas_h);
  d->textures_.push_back(d->cc_map_);
  gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, atlas_w, atlas_h, GL_RGBA_INTEGER, GL_INT, cc_map.data());
  // Zero light until set_light (Backend: "zero until set").
  d->zeros_.assign(d->sizes_.clutter_ld, 0.0f);
  upload_linear(gl, d->clutter_ld_, GL_RGB, GL_FLOAT, 3, d->zeros_.data(), d->sizes_.clutter_texels,
                sizeof(float));
  upload_linear(gl, d->clutter_direct_, GL_RGB, GL_FLOAT, 3, d->zeros_.data(), d->sizes_.clutter_texels,
                sizeof(float));

  // ---- targets ----
  auto target = [&](const char* name, int width, int height, GLenum format, const char* format_name,
                    Target& out) -> Status {
    if (height > setup.max_texture_size)
      return Status::error(ErrorCode::resource_limit,
                           std::string("gles drt: ") + name + " exceeds GL_MAX_TEXTURE_SIZE");
    out.width = width;
    out.height = height;
    out.texture = create_texture(gl, format, width, height);
    d->textures_.push_back(out.texture);
    Result<GLuint> fb = create_framebuffer(gl, name, {out.texture}, format_name);
    if (!fb.ok()) return fb.status();
    out.framebuffer = fb.value();
    d->framebuffers_.push_back(fb.value());
    return Status::success();
  };
  if (Status s = target("c", kLinearWidth, linear_rows(face0), GL_RGBA32UI, "RGBA32UI", d->c_); !s.ok())
    return s;
  if (Status s = target("clutter feedback", kLinearWidth, linear_rows(d->sizes_.clutter_texels), GL_RGBA32UI,
                        "RGBA32UI", d->fed_);
      !s.ok())
    return s;
  for (auto [pass, name, rows, items] : {std::tuple{&d->scalar_, "DRT delta", 1, samples},
                                         std::tuple{&d->vector_, "DRT vector delta", 4, samples},
                                         std::tuple{&d->probes_, "DRT probe delta", 9, setup.probe_count}}) {
    if (!pass->entries) continue;
    pass->rows = rows;
    pass->count = std::size_t(rows) * items;
    if (Status s =
            target(name, kLinearWidth, linear_rows(pass->count), GL_RGBA32UI, "RGBA32UI", pass->target);
        !s.ok())
      return s;
  }
  if (Status s = target("Vc b", kLinearWidth, linear_rows(mode0), GL_RGBA32UI, "RGBA32UI", d->y_); !s.ok())
    return s;
  if (d->gather_) {
    if (Status s = target("gather x_s", kLinearWidth, linear_rows(samples), GL_RGBA32UI, "RGBA32UI", d->xs_);
        !s.ok())
      return s;
    if (Status s = target("gather x_t", kLinearWidth, linear_rows(d->sizes_.clutter_texels), GL_RGBA32UI,
                          "RGBA32UI", d->xt_);
        !s.ok())
      return s;
  }
  if (Status s = target("clutter atlas", atlas_w, atlas_h, setup.output_format, setup.output_format_name,
                        d->clutter_);
      !s.ok())
    return s;
  if (d->has_vector_) {
    if (Status s = target("Vc_vec b", kLinearWidth, linear_rows(std::max<std::size_t>(mode0_vec, 1)),
                          GL_RGBA32UI, "RGBA32UI", d->y_vec_);
        !s.ok())
      return s;
    if (Status s = target("vector clutter", kLinearWidth, linear_rows(vec_rows), setup.output_format,
                          setup.output_format_name, d->clutter_vec_);
        !s.ok())
      return s;
  }
  d->readback_.assign(4 * std::max(std::size_t(atlas_w) * std::size_t(atlas_h),
                                   std::size_t(d->clutter_vec_.width) * std::size_t(d->clutter_vec_.height)),
                      0.0f);

  // ---- programs ----
  // with_gather: built with GATHER, drt_gather.glsl between common.glsl and the pass.
  auto program = [&](const char* name, const char* fragment, GLuint& out,
                     std::initializer_list<const char*> samplers, int count, const std::string& extra = {},
                     bool with_gather = false) -> Status {
    const std::string head = *setup.defines + extra + (with_gather ? "#define GATHER 1\n" : "");
    Result<GLuint> p = build_program(gl, name, {"#version 300 es\n", kFullscreenVert},
                                     {head.c_str(), kCommon, with_gather ? kDrtGather : "", fragment});
    if (!p.ok()) return p.status();
    out = p.value();
    d->programs_.push_back(out);
    gl.glUseProgram(out);
    assign_sampler_units(gl, out, samplers);
    if (count >= 0) set_int(gl, out, "u_count", count);
    return Status::success();
  };
  if (Status s =
          program("drt_c.frag", kDrtCFrag, d->prog_c_, {"u_td_c", "u_face_info", "u_clutter_ld"}, int(face0));
      !s.ok())
    return s;
  if (Status s = program("drt_c.frag (FEEDBACK)", kDrtCFrag, d->prog_c_fed_,
                         {"u_td_c", "u_face_info", "u_clutter_ld"}, int(face0), "#define FEEDBACK 1\n");
      !s.ok())
    return s;
  if (Status s = program("drt_feedback.frag", kDrtFeedbackFrag, d->prog_feedback_,
                         {"u_clutter_ld", "u_rho", "u_direct", "u_texel_xy", "u_atlas", "u_ld_max"},
                         int(d->sizes_.clutter_texels));
      !s.ok())
    return s;
  d->u_feedback_bound_ = gl.glGetUniformLocation(d->prog_feedback_, "u_bound");
  d->u_feedback_scale_ = gl.glGetUniformLocation(d->prog_feedback_, "u_bound_scale");
  d->u_feedback_clutter_max_ = gl.glGetUniformLocation(d->prog_feedback_, "u_clutter_ld_max");
  if (Status s = program("drt_feedback.frag (LINEAR)", kDrtFeedbackFrag, d->prog_feedback_linear_,
                         {"u_clutter_ld", "u_rho", "u_direct", "u_texel_xy", "u_atlas", "u_ld_max"},
                         int(d->sizes_.clutter_texels), "#define LINEAR 1\n");
      !s.ok())
    return s;
  d->u_linear_scale_ = gl.glGetUniformLocation(d->prog_feedback_linear_, "u_scale");
  // The gather's samplers come last; a program without them ignores their names.
  for (DeltaPass* pass : {&d->scalar_, &d->vector_, &d->probes_}) {
    if (!pass->entries) continue;
    const bool with_gather = d->gather_ && pass == &d->scalar_;
    if (Status s =
            program(with_gather ? "drt_delta.frag (GATHER)" : "drt_delta.frag", kDrtDeltaFrag, pass->program,
                    {"u_dub", "u_duc", "u_item_entries", "u_entries", "u_b_red", "u_b_green", "u_b_blue",
                     "u_c", "u_gather", "u_xs", "u_xt"},
                    int(pass->count), "#define DELTA_ROWS " + std::to_string(pass->rows) + "\n", with_gather);
        !s.ok())
      return s;
  }
  if (Status s =
          program("drt_vc.frag", kDrtVcFrag, d->prog_vc_,
                  {"u_vc", "u_mode_info", "u_cb_blocks", "u_b_red", "u_b_green", "u_b_blue"}, int(mode0));
      !s.ok())
    return s;
  if (Status s = program(d->gather_ ? "drt_clutter.frag (GATHER)" : "drt_clutter.frag", kDrtClutterFrag,
                         d->prog_clutter_,
                         {"u_texel_map", "u_uc", "u_y", "u_direct", "u_cc_map", "u_cc", "u_cc_faces", "u_c",
                          "u_gather_texels", "u_gather", "u_xs", "u_xt"},
                         -1, {}, d->gather_);
      !s.ok())
    return s;
  if (d->gather_) {
    if (Status s =
            program("drt_light.frag (ld)", kDrtLightFrag, d->prog_light_ld_, {"u_light"}, int(samples));
        !s.ok())
      return s;
    if (Status s = program("drt_light.frag (clutter_ld)", kDrtLightFrag, d->prog_light_clutter_, {"u_light"},
                           int(d->sizes_.clutter_texels));
        !s.ok())
      return s;
  }
  if (d->has_vector_) {
    if (Status s = program("drt_vc.frag (vector)", kDrtVcFrag, d->prog_vc_vec_,
                           {"u_vc", "u_mode_info", "u_cb_blocks", "u_b_red", "u_b_green", "u_b_blue"},
                           int(mode0_vec));
        !s.ok())
      return s;
    if (Status s =
            program("drt_clutter.frag (vector)", kDrtClutterFrag, d->prog_clutter_vec_,
                    {"u_texel_map", "u_uc", "u_y", "u_direct", "u_cc_map", "u_cc", "u_cc_faces", "u_c"}, -1,
                    "#define NO_DIRECT 1\n");
        !s.ok())
      return s;
  }
  gl.glUseProgram(0);
  return d;
}

void GlesDrt::draw(GLuint program, const Target& target, std::initializer_list<GLuint> textures) {
  gl_.glBindFramebuffer(GL_FRAMEBUFFER, target.framebuffer);
  gl_.glViewport(0, 0, target.width, target.height);
  gl_.glUseProgram(program);
  GLenum unit = GL_TEXTURE0;
  for (GLuint t : textures) {
    gl_.glActiveTexture(unit++);
    gl_.glBindTexture(GL_TEXTURE_2D, t);
  }
  gl_.glDrawArrays(GL_TRIANGLES, 0, 3);
}

void GlesDrt::set_light(std::span<const float> clutter_ld, std::span<const float> clutter_direct) {
  upload_linear(gl_, clutter_ld_, GL_RGB, GL_FLOAT, 3, clutter_ld.data(), sizes_.clutter_texels,
                sizeof(float));
  upload_linear(gl_, clutter_direct_, GL_RGB, GL_FLOAT, 3,
                clutter_direct.empty() ? zeros_.data() : clutter_direct.data(), sizes_.clutter_texels,
                sizeof(float));
  light_changed_ = true;
  xt_current_ = false;
}

void GlesDrt::set_albedo(std::span<const float> rho_c) {
  feed_ = !rho_c.empty();
  light_changed_ = true;  // c returns to the direct light's
  if (feed_)
    upload_linear(gl_, rho_c_, GL_RGB, GL_FLOAT, 3, rho_c.data(), sizes_.clutter_texels, sizeof(float));
}

void GlesDrt::run_scene(const std::array<GLuint, 3>& b, const GlesDrtLd& ld, bool feedback,
                        const ClutterFeedback& bound, GLuint ld_max_texture, bool keep_c) {
  bool fed = false;  // x_t is the light fed back (ClutterBuffers::radiance)
  if (keep_c) {
    light_changed_ = true;  // the next update() starts again from the direct light
  } else if (feedback && feed_) {
    // The clutter atlas still holds the last evaluation's light (run_clutter comes after).
    gl_.glUseProgram(prog_feedback_);
    gl_.glUniform1f(u_feedback_bound_, bound.bound());
    // With the walls' ld on the GPU: drt_feedback_bound at ld_max 1 and no clutter light is the
    // scale 1 / (1 - max albedo); the shader takes the larger of the two lights' maxima.
    gl_.glUniform1f(u_feedback_scale_,
                    ld_max_texture ? drt_feedback_bound(1.0f, bound.rho_max, 0.0f, bound.rho_c_max) : 0.0f);
    gl_.glUniform1f(u_feedback_clutter_max_, bound.clutter_ld_max);
    draw(prog_feedback_, fed_,
         {clutter_ld_, rho_c_, clutter_direct_, texel_xy_, clutter_.texture, ld_max_texture});
    draw(prog_c_fed_, c_, {td_c_, face_info_, fed_.texture});
    light_changed_ = true;  // the next update() starts again from the direct light
    fed = true;
  } else if (light_changed_) {  // c depends on the clutter's light only
    draw(prog_c_, c_, {td_c_, face_info_, clutter_ld_});
    light_changed_ = false;
  }
  if (gather_) gather_inputs(ld, fed);
  for (const DeltaPass* pass : {&scalar_, &vector_, &probes_}) {
    if (!pass->entries) continue;
    if (gather_ && pass == &scalar_)
      draw(pass->program, pass->target,
           {pass->dub, pass->duc, pass->item_entries, pass->entries, b[0], b[1], b[2], c_.texture,
            gather_entries_, xs_signal_, xt_signal_});
    else
      draw(pass->program, pass->target,
           {pass->dub, pass->duc, pass->item_entries, pass->entries, b[0], b[1], b[2], c_.texture});
  }
}

void GlesDrt::gather_inputs(const GlesDrtLd& ld, bool fed) {
  if (ld.signal) {
    xs_signal_ = ld.texture;
  } else {
    gl_.glBindSampler(0, ld.sampler);  // u_light: the caller's texture reads texel by texel
    draw(prog_light_ld_, xs_, {ld.texture});
    gl_.glBindSampler(0, 0);
    xs_signal_ = xs_.texture;
  }
  if (fed) {
    xt_signal_ = fed_.texture;
    return;
  }
  if (!xt_current_) {  // clutter_ld changed since its last copy
    draw(prog_light_clutter_, xt_, {clutter_ld_});
    xt_current_ = true;
  }
  xt_signal_ = xt_.texture;
}

void GlesDrt::solve_start() { draw(prog_c_, c_, {td_c_, face_info_, clutter_ld_}); }

void GlesDrt::solve_step(const std::array<GLuint, 3>& b, float scale) {
  if (scalar_.entries)
    draw(scalar_.program, scalar_.target,
         {scalar_.dub, scalar_.duc, scalar_.item_entries, scalar_.entries, b[0], b[1], b[2], c_.texture});
  if (!feed_) return;  // no clutter albedo: c stays c0
  run_clutter(b);      // Cb b + Cc c (+ the direct light, which drt_feedback.frag takes off)
  gl_.glUseProgram(prog_feedback_linear_);
  gl_.glUniform1f(u_linear_scale_, scale);
  draw(prog_feedback_linear_, fed_, {clutter_ld_, rho_c_, clutter_direct_, texel_xy_, clutter_.texture, 0});
  draw(prog_c_fed_, c_, {td_c_, face_info_, fed_.texture});
}

void GlesDrt::run_clutter(const std::array<GLuint, 3>& b) {
  draw(prog_vc_, y_, {vc_, mode_info_, cb_blocks_, b[0], b[1], b[2]});
  if (gather_)
    draw(prog_clutter_, clutter_,
         {texel_map_, uc_, y_.texture, clutter_direct_, cc_map_, cc_, cc_faces_, c_.texture, gather_texels_,
          gather_entries_, xs_signal_, xt_signal_});
  else
    draw(prog_clutter_, clutter_,
         {texel_map_, uc_, y_.texture, clutter_direct_, cc_map_, cc_, cc_faces_, c_.texture});
}

Status GlesDrt::read_clutter_vector_lightmap(const std::array<GLuint, 3>& b, std::span<float> out) {
  if (out.size() != sizes_.clutter_vector_lightmap)
    return wrong_size("clutter vector lightmap", out.size(), sizes_.clutter_vector_lightmap);
  if (!has_vector_) {  // no object has vector operators: zeros (drt_clutter_vector_lightmap)
    std::fill(out.begin(), out.end(), 0.0f);
    return Status::success();
  }
  draw(prog_vc_vec_, y_vec_, {vc_vec_, mode_info_vec_, cb_blocks_vec_, b[0], b[1], b[2]});
  draw(prog_clutter_vec_, clutter_vec_,
       {vec_map_, uc_vec_, y_vec_.texture, clutter_direct_, vec_cc_map_, cc_vec_, cc_faces_vec_, c_.texture});
  read_back(clutter_vec_);
  for (std::size_t r = 0; r < out.size() / 3; ++r)
    for (std::size_t ch = 0; ch < 3; ++ch) out[3 * r + ch] = readback_[4 * r + ch];
  return Status::success();
}

void GlesDrt::read_back(const Target& target) {
  gl_.glBindFramebuffer(GL_FRAMEBUFFER, target.framebuffer);
  gl_.glReadBuffer(GL_COLOR_ATTACHMENT0);
  gl_.glPixelStorei(GL_PACK_ALIGNMENT, 4);
  // RGBA32UI holds float bit patterns: read as unsigned ints into float storage, exactly.
  if (output_bits_)
    gl_.glReadPixels(0, 0, target.width, target.height, GL_RGBA_INTEGER, GL_UNSIGNED_INT, readback_.data());
  else
    gl_.glReadPixels(0, 0, target.width, target.height, GL_RGBA, GL_FLOAT, readback_.data());
  gl_.glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

Status GlesDrt::read_clutter_lightmap(std::span<float> out) {
  if (out.size() != sizes_.clutter_lightmap)
    return wrong_size("clutter lightmap", out.size(), sizes_.clutter_lightmap);
  read_back(clutter_);
  for (std::size_t i = 0; i < drt_->objects.size(); ++i)
    for (std::uint32_t t = 0; t < drt_->objects[i].texel_count; ++t) {
      const std::array<int, 2> xy = clutter_texel(i, t);
      const std::size_t src = 4 * (std::size_t(xy[1]) * std::size_t(clutter_.width) + std::size_t(xy[0]));
      for (std::size_t ch = 0; ch < 3; ++ch) out[3 * (texel0_[i] + t) + ch] = readback_[src + ch];
    }
  return Status::success();
}

}  // namespace modrt::gles
