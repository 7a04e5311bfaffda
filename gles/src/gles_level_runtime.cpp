// SPDX-License-Identifier: MIT
#include "modrt/gles/gles_level_runtime.h"
#include "modrt/feedback_policy.h"
#include "modrt/sh.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <string>
#include <tuple>

#include "gl_objects.h"
#include "gles_drt.h"
#include "modrt/reference_runtime.h"

namespace modrt::gles {

// Shader sources, generated from gles/shaders/*.glsl by cmake/EmbedShaders.cmake.
extern const char* const kCommon;
extern const char* const kFullscreenVert;
extern const char* const kBFrag;
extern const char* const kReduceFrag;
extern const char* const kRFrag;
extern const char* const kAtlasFrag;
extern const char* const kFeedbackFrag;
extern const char* const kLdMaxFrag;
extern const char* const kProbesWorldFrag;
extern const char* const kProbesFrag;
extern const char* const kVectorFrag;

const char* target_format_name(TargetFormat f) {
  switch (f) {
    case TargetFormat::float32: return "float32";
    case TargetFormat::float16: return "float16";
    case TargetFormat::bits32: return "bits32";
  }
  return "unknown";
}

const char* operator_format_name(OperatorFormat f) {
  return f == OperatorFormat::float16 ? "float16" : "float32";
}

std::string glsl_float(float v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9e", double(v));
  return text;
}

namespace {

// Samples per partial sum in b.frag: enough independent fragments to fill a GPU, few enough
// partials (n / 64) for b_reduce.frag to add cheaply.
constexpr int kBChunk = 64;

// Timer scopes, one per pass.
enum Scope { kUpload, kFeedback, kB, kR, kAtlas, kProbes, kVector, kDrt, kClutter, kScopeCount };

int groups_of(std::size_t modes) { return int((modes + 3) / 4); }

Status wrong_size(const char* what, std::size_t got, std::size_t expected) {
  return Status::error(ErrorCode::invalid_argument, std::string("gles: ") + what + ": has " +
                                                        std::to_string(got) + " floats, expected " +
                                                        std::to_string(expected));
}

GLenum output_internal_format(TargetFormat f) {
  switch (f) {
    case TargetFormat::float32: return GL_RGBA32F;
    case TargetFormat::float16: return GL_RGBA16F;
    case TargetFormat::bits32: return GL_RGBA32UI;
  }
  return GL_RGBA32F;
}

// Packs `m` (rows x cols, row-major) four columns per RGBA texel: texel (row_base + r) *
// groups + g holds m[r][4g..4g+3], zero beyond cols.
void pack_rows(const Matrix& m, std::size_t row_base, int groups, std::vector<float>& out) {
  for (std::uint32_t r = 0; r < m.rows; ++r)
    for (std::uint32_t c = 0; c < m.cols; ++c) out[((row_base + r) * std::size_t(groups)) * 4 + c] = m(r, c);
}

// Packs the transpose-friendly layout of Td_b (kb x n): texel (block_base + g) * n_max + t
// holds Td_b[4g..4g+3][t].
void pack_columns(const Matrix& m, std::size_t group_base, std::size_t n_max, std::vector<float>& out) {
  for (std::uint32_t r = 0; r < m.rows; ++r)
    for (std::uint32_t t = 0; t < m.cols; ++t) out[((group_base + r / 4) * n_max + t) * 4 + r % 4] = m(r, t);
}

}  // namespace

GlesLevelRuntime::GlesLevelRuntime(const platform::GlFunctions& gl, const Level& level,
                                   const Dictionary& dict, const GlesRuntimeOptions& options)
    : StagedBackend(level, dict, StagedBackendOptions{options.probes, options.skip_unchanged}, "gles"),
      gl_(gl) {}

GlesLevelRuntime::~GlesLevelRuntime() {
  timer_.reset();
  drt_.reset();
  for (GLuint p : programs_) gl_.glDeleteProgram(p);
  if (!framebuffers_.empty()) gl_.glDeleteFramebuffers(GLsizei(framebuffers_.size()), framebuffers_.data());
  if (!textures_.empty()) gl_.glDeleteTextures(GLsizei(textures_.size()), textures_.data());
  if (vao_) gl_.glDeleteVertexArrays(1, &vao_);
  if (ld_sampler_) gl_.glDeleteSamplers(1, &ld_sampler_);
}

Result<std::unique_ptr<GlesLevelRuntime>> GlesLevelRuntime::create(const platform::GlFunctions& gl,
                                                                   bool gles_context, const Level& level,
                                                                   const Dictionary& dict,
                                                                   const GlesRuntimeOptions& options) {
  if (!gl.glGetError) return Status::error(ErrorCode::invalid_argument, "gles: GL functions are not loaded");
  if (Status s = check_level_operators(level, dict); !s.ok()) return s;
  std::unique_ptr<GlesLevelRuntime> rt(new GlesLevelRuntime(gl, level, dict, options));
  while (gl.glGetError() != GL_NO_ERROR) {
  }  // errors left by the caller are not ours
  if (Status s = rt->build(level, dict, gles_context, options); !s.ok()) return s;
  return rt;
}

Status GlesLevelRuntime::check(const char* what) const {
  if (!options_.check_errors) return Status::success();
  const GLenum e = gl_.glGetError();
  if (e == GL_NO_ERROR) return Status::success();
  while (gl_.glGetError() != GL_NO_ERROR) {
  }
  return Status::error(ErrorCode::internal_error,
                       std::string("gles: ") + what + ": " + platform::gl_error_name(e));
}

Status GlesLevelRuntime::build(const Level& level, const Dictionary& dict, bool gles_context,
                               const GlesRuntimeOptions& options) {
  level_ = &level;
  dict_ = &dict;
  options_ = options;
  groups_ = groups_of(level.kb);
  r_groups_ = groups_of(level.kr);
  for (const ShapeOperators& op : dict.shapes) n_max_ = std::max(n_max_, int(op.sample_count()));
  probe_rows_ = dict.shapes.empty() ? 0 : int(dict.shapes[0].Ubvol.rows);
  b_chunks_ = std::max(1, (n_max_ + kBChunk - 1) / kBChunk);
  has_probes_ = options.probes && probe_rows_ > 0;
  if (options.vector_irradiance) {
    if (Status s = check_level_vector_operators(level, dict); !s.ok())
      return Status::error(ErrorCode::invalid_argument,
                           "gles: vector_irradiance is on, but " + s.message() +
                               " (bake the dictionary with format version 2 or turn vector_irradiance off)");
    has_vector_ = true;
    vector_rows_ = int(4 * dict.interfaces.Ur.rows);
  }
  gl_.glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_texture_size_);

  // ---- target format: requested, or the best the context renders to ----
  const bool float_rt = !gles_context || platform::has_gl_extension(gl_, "GL_EXT_color_buffer_float");
  const bool half_rt = float_rt || platform::has_gl_extension(gl_, "GL_EXT_color_buffer_half_float");
  if (options.target) {
    target_ = *options.target;
    if ((target_ == TargetFormat::float32 && !float_rt) || (target_ == TargetFormat::float16 && !half_rt))
      return Status::error(
          ErrorCode::invalid_argument,
          std::string("gles: ") + target_format_name(target_) + " render targets need EXT_color_buffer_" +
              (target_ == TargetFormat::float32 ? "float" : "half_float") +
              ", which this context lacks; use bits32 (exact, RGBA32UI) or leave the format unset");
  } else {
    target_ = float_rt ? TargetFormat::float32 : half_rt ? TargetFormat::float16 : TargetFormat::bits32;
  }
  const GLenum output_format = output_internal_format(target_);
  const GLenum op_format = options.operators == OperatorFormat::float16 ? GL_RGBA16F : GL_RGBA32F;
  output_format_ = output_format;
  operator_format_ = op_format;
  description_ = std::string("gles ") + target_format_name(target_) + " targets, " +
                 operator_format_name(options.operators) + " operators" +
                 (has_vector_ ? ", vector irradiance" : "");

  // ---- integer tables ----
  const std::size_t blocks = level.blocks.size(), slots = level.slots.size(), samples = level.sample_count;
  std::vector<std::int32_t> block_info(4 * std::max<std::size_t>(blocks, 1), 0);
  std::vector<std::int32_t> block_slots(4 * std::max<std::size_t>(blocks, 1), -1);
  for (std::size_t i = 0; i < blocks; ++i) {
    const LevelBlock& b = level.blocks[i];
    block_info[4 * i + 0] = int(operator_set(dict, b));
    block_info[4 * i + 1] = std::int32_t(b.sample_offset);
    block_info[4 * i + 2] = std::int32_t(b.sample_count);
    // probes_world.frag reads the turns, common.glsl's block_groups the modes.
    block_info[4 * i + 3] = (b.quarter_turns & 3) | (groups_of(block_kb(dict, level, b)) << 2);
  }
  // Records grouped by slot (stable), so r.frag walks one contiguous range per slot.
  std::vector<std::uint32_t> order(level.records.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return level.records[a].slot < level.records[b].slot;
  });
  std::vector<std::int32_t> slot_info(4 * std::max<std::size_t>(slots, 1), 0);
  for (std::size_t s = 0; s < slots; ++s) {
    slot_info[4 * s + 2] = std::int32_t(level.slots[s].block);
    slot_info[4 * s + 3] = level.slots[s].entry_face;
  }
  std::vector<std::int32_t> record_block(4 * std::max<std::size_t>(order.size(), 1), 0);
  for (std::size_t j = 0; j < order.size(); ++j) {
    const ResponseRecord& rec = level.records[order[j]];
    record_block[4 * j] = std::int32_t(rec.source_block);
    record_block[4 * j + 1] = groups_of(rec.T.cols);  // r.frag: the source's modes
    if (slot_info[4 * rec.slot + 1]++ == 0) slot_info[4 * rec.slot] = std::int32_t(j);
  }
  std::vector<std::int32_t> sample_info(4 * std::max<std::size_t>(samples, 1), 0);
  std::vector<std::int32_t> sample_slots(4 * std::max<std::size_t>(samples, 1), -1);
  std::vector<std::int32_t> sample_rows(4 * std::max<std::size_t>(samples, 1), -1);
  const LightmapAtlas& atlas = level.atlas;
  for (std::size_t i = 0; i < blocks; ++i) {
    const LevelBlock& b = level.blocks[i];
    for (std::uint32_t t = 0; t < b.sample_count; ++t) {
      const std::size_t s = b.sample_offset + t;
      const std::uint32_t texel = atlas.sample_texel.empty() ? 0 : atlas.sample_texel[s];
      sample_info[4 * s + 0] = std::int32_t(i);
      sample_info[4 * s + 1] = std::int32_t(t);
      sample_info[4 * s + 2] = atlas.width > 0 ? std::int32_t(texel % std::uint32_t(atlas.width)) : 0;
      sample_info[4 * s + 3] = atlas.width > 0 ? std::int32_t(texel / std::uint32_t(atlas.width)) : 0;
    }
  }
  for (std::size_t s = 0; s < slots; ++s) {
    const ResponseSlot& slot = level.slots[s];
    const LevelBlock& b = level.blocks[slot.block];
    int k = 0;
    while (k < 4 && block_slots[4 * slot.block + std::size_t(k)] >= 0) ++k;
    if (k == 4)
      return Status::error(ErrorCode::invalid_argument, "gles: block " + std::to_string(slot.block) +
                                                            " has more than four response slots");
    block_slots[4 * slot.block + std::size_t(k)] = std::int32_t(s);
    for (std::size_t row = 0; row < slot.ur_row_to_sample.size(); ++row) {
      const std::int32_t local = slot.ur_row_to_sample[row];
      if (local < 0) continue;
      const std::size_t g = b.sample_offset + std::size_t(local);
      int m = 0;
      while (m < 4 && sample_slots[4 * g + std::size_t(m)] >= 0) ++m;
      if (m == 4)
        return Status::error(ErrorCode::invalid_argument,
                             "gles: sample " + std::to_string(g) + " receives more than four response slots");
      sample_slots[4 * g + std::size_t(m)] = std::int32_t(s);
      sample_rows[4 * g + std::size_t(m)] = std::int32_t(row);
    }
  }
  // Which sample each atlas texel shows: interior texels their own, padding texels what the
  // padding records copy into them (replayed in order, exactly as level_fill_atlas does).
  const std::size_t atlas_texels =
      std::size_t(std::max(atlas.width, 0)) * std::size_t(std::max(atlas.height, 0));
  std::vector<std::int32_t> texel_sample(std::max<std::size_t>(atlas_texels, 1), -1);
  for (std::size_t s = 0; s < atlas.sample_texel.size(); ++s)
    texel_sample[atlas.sample_texel[s]] = std::int32_t(s);
  for (const PaddingRecord& p : atlas.padding) texel_sample[p.dst] = texel_sample[p.src];

  // ---- operators, packed four modes per texel ----
  const std::size_t shapes = operator_set_count(dict, level);
  std::vector<float> td_b(4 * std::max<std::size_t>(shapes * std::size_t(groups_) * std::size_t(n_max_), 1),
                          0.0f);
  std::vector<float> ub(4 * std::max<std::size_t>(shapes * std::size_t(n_max_) * std::size_t(groups_), 1),
                        0.0f);
  for (std::size_t sh = 0; sh < shapes; ++sh) {
    pack_columns(operator_set_at(dict, level, sh).Td_b, sh * std::size_t(groups_), std::size_t(n_max_), td_b);
    pack_rows(operator_set_at(dict, level, sh).Ub, sh * std::size_t(n_max_), groups_, ub);
  }
  const Matrix& Ur = dict.interfaces.Ur;
  std::vector<float> ur(4 * std::max<std::size_t>(std::size_t(Ur.rows) * std::size_t(r_groups_), 1), 0.0f);
  if (!Ur.empty()) pack_rows(Ur, 0, r_groups_, ur);
  // Records: texel ((j * r_groups + go) * groups + gi) * 4 + c = T[4go..4go+3][4gi + c].
  const std::size_t per_record = std::size_t(r_groups_) * std::size_t(groups_) * 4;
  std::vector<float> t(4 * std::max<std::size_t>(order.size() * per_record, 1), 0.0f);
  for (std::size_t j = 0; j < order.size(); ++j) {
    const Matrix& T = level.records[order[j]].T;
    for (std::uint32_t row = 0; row < T.rows; ++row)
      for (std::uint32_t col = 0; col < T.cols; ++col) {
        const std::size_t texel =
            ((j * std::size_t(r_groups_) + row / 4) * std::size_t(groups_) + col / 4) * 4 + col % 4;
        t[4 * texel + row % 4] = T(row, col);
      }
  }
  std::vector<float> ubvol, probe_response;
  if (has_probes_) {
    const std::size_t rows = std::size_t(probe_rows_);
    ubvol.assign(4 * shapes * rows * std::size_t(groups_), 0.0f);
    for (std::size_t sh = 0; sh < shapes; ++sh)
      pack_rows(operator_set_at(dict, level, sh).Ubvol, sh * rows, groups_, ubvol);
    probe_response.assign(4 * kFaceCount * rows * std::size_t(r_groups_), 0.0f);
    for (std::size_t f = 0; f < std::size_t(kFaceCount); ++f)
      if (level.probe_response[f].rows == rows)
        pack_rows(level.probe_response[f], f * rows, r_groups_, probe_response);
  }

  std::vector<float> ub_vec, vector_response;
  if (has_vector_) {
    const std::size_t rows = std::size_t(vector_rows_);
    ub_vec.assign(4 * shapes * std::size_t(n_max_) * 4 * std::size_t(groups_), 0.0f);
    for (std::size_t sh = 0; sh < shapes; ++sh)
      if (!operator_set_at(dict, level, sh).Ub_vec.empty())
        pack_rows(operator_set_at(dict, level, sh).Ub_vec, sh * std::size_t(n_max_) * 4, groups_, ub_vec);
    vector_response.assign(4 * std::max<std::size_t>(kFaceCount * rows * std::size_t(r_groups_), 1), 0.0f);
    for (std::size_t f = 0; f < std::size_t(kFaceCount); ++f)
      if (level.vector_response[f].rows == rows)
        pack_rows(level.vector_response[f], f * rows, r_groups_, vector_response);
  }

  // ---- textures ----
  Status limit;
  auto linear_texture = [&](const char* name, GLenum format, std::size_t texels) -> GLuint {
    const int rows = linear_rows(texels);
    if (rows > max_texture_size_ && limit.ok())
      limit = Status::error(
          ErrorCode::resource_limit,
          std::string("gles: ") + name + " needs a " + std::to_string(kLinearWidth) + " x " +
              std::to_string(rows) + " texture, over this context's GL_MAX_TEXTURE_SIZE " +
              std::to_string(max_texture_size_) + ": the level is too large for the GLES backend");
    const GLuint tex =
        create_texture(gl_, format, kLinearWidth, std::min(rows, std::max(max_texture_size_, 1)));
    textures_.push_back(tex);
    return tex;
  };
  auto float_table = [&](const char* name, GLenum format, const std::vector<float>& data) {
    const GLuint tex = linear_texture(name, format, data.size() / 4);
    if (limit.ok())
      upload_linear(gl_, tex, GL_RGBA, GL_FLOAT, 4, data.data(), data.size() / 4, sizeof(float));
    return tex;
  };
  auto int_table = [&](const char* name, const std::vector<std::int32_t>& data) {
    const GLuint tex = linear_texture(name, GL_RGBA32I, data.size() / 4);
    if (limit.ok())
      upload_linear(gl_, tex, GL_RGBA_INTEGER, GL_INT, 4, data.data(), data.size() / 4, sizeof(std::int32_t));
    return tex;
  };
  td_b_ = float_table("Td_b", op_format, td_b);
  ub_ = float_table("Ub", op_format, ub);
  ur_ = float_table("Ur", op_format, ur);
  t_ = float_table("Tb_r records", op_format, t);
  if (has_probes_) {
    ubvol_ = float_table("Ubvol", op_format, ubvol);
    probe_response_ = float_table("probe response", op_format, probe_response);
  }
  if (has_vector_) {
    ub_vec_ = float_table("Ub_vec", op_format, ub_vec);
    vector_response_ = float_table("vector response", op_format, vector_response);
  }
  block_info_ = int_table("block table", block_info);
  block_slots_ = int_table("block slot table", block_slots);
  slot_info_ = int_table("slot table", slot_info);
  record_block_ = int_table("record table", record_block);
  sample_info_ = int_table("sample table", sample_info);
  sample_slots_ = int_table("sample slot table", sample_slots);
  sample_rows_ = int_table("sample row table", sample_rows);
  const int atlas_w = std::max(atlas.width, 1), atlas_h = std::max(atlas.height, 1);
  if (atlas_w > max_texture_size_ || atlas_h > max_texture_size_)
    return Status::error(ErrorCode::resource_limit, "gles: the lightmap atlas (" + std::to_string(atlas_w) +
                                                        " x " + std::to_string(atlas_h) +
                                                        ") exceeds GL_MAX_TEXTURE_SIZE " +
                                                        std::to_string(max_texture_size_));
  texel_sample_ = create_texture(gl_, GL_R32I, atlas_w, atlas_h);
  textures_.push_back(texel_sample_);
  gl_.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  gl_.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, atlas_w, atlas_h, GL_RED_INTEGER, GL_INT, texel_sample.data());
  // Per-frame inputs: RGB32F so that the caller's interleaved RGB uploads without repacking.
  const int feedback_rows = linear_rows(samples);
  ld_ = linear_texture("ld", GL_RGB32F, samples);
  ld_source_ = ld_;
  gl_.glGenSamplers(1, &ld_sampler_);
  gl_.glSamplerParameteri(ld_sampler_, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  gl_.glSamplerParameteri(ld_sampler_, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  ld_direct_ = linear_texture("ld_direct", GL_RGB32F, samples);
  feedback_source_ = ld_direct_;
  rho_ = linear_texture("albedo", GL_RGB32F, samples);
  if (!limit.ok()) return limit;
  if (Status s = check("uploading operators"); !s.ok()) return s;

  // ---- signal targets ----
  const char* fmt = target_format_name(target_);
  auto signal3 = [&](const char* name, std::size_t texels, Signal3& out) -> Status {
    out.width = kLinearWidth;
    out.height = linear_rows(texels);
    if (out.height > max_texture_size_)
      return Status::error(ErrorCode::resource_limit,
                           std::string("gles: ") + name + " exceeds GL_MAX_TEXTURE_SIZE");
    for (GLuint& tex : out.textures) {
      tex = create_texture(gl_, GL_RGBA32UI, out.width, out.height);
      textures_.push_back(tex);
    }
    Result<GLuint> fb =
        create_framebuffer(gl_, name, {out.textures[0], out.textures[1], out.textures[2]}, "RGBA32UI");
    if (!fb.ok()) return fb.status();
    out.framebuffer = fb.value();
    framebuffers_.push_back(fb.value());
    return Status::success();
  };
  auto target = [&](const char* name, int width, int height, GLenum format, Target& out) -> Status {
    if (height > max_texture_size_)
      return Status::error(ErrorCode::resource_limit,
                           std::string("gles: ") + name + " exceeds GL_MAX_TEXTURE_SIZE");
    out.width = width;
    out.height = height;
    out.texture = create_texture(gl_, format, width, height);
    textures_.push_back(out.texture);
    Result<GLuint> fb =
        create_framebuffer(gl_, name, {out.texture}, format == GL_RGBA32UI ? "RGBA32UI" : fmt);
    if (!fb.ok()) return fb.status();
    out.framebuffer = fb.value();
    framebuffers_.push_back(fb.value());
    return Status::success();
  };
  if (Status s =
          signal3("b partial sums", blocks * std::size_t(groups_) * std::size_t(b_chunks_), b_partial_);
      !s.ok())
    return s;
  if (Status s = signal3("b", blocks * std::size_t(groups_), b_); !s.ok()) return s;
  if (Status s = signal3("r partial sums", slots * std::size_t(r_groups_) * std::size_t(groups_), r_partial_);
      !s.ok())
    return s;
  if (Status s = signal3("r", slots * std::size_t(r_groups_), r_); !s.ok()) return s;
  // The converged solve's signals (b-sized, small); its operators come with the first solve.
  if (Status s = signal3("reduced solve c", blocks * std::size_t(groups_), solve_.rhs); !s.ok()) return s;
  for (Signal3& x : solve_.x)
    if (Status s = signal3("reduced solve x", blocks * std::size_t(groups_), x); !s.ok()) return s;
  if (Status s = signal3("reduced solve u", blocks * std::size_t(groups_), solve_.u); !s.ok()) return s;
  if (Status s = target("reduced solve residual", 1, 1, GL_RGBA32UI, solve_.residual); !s.ok()) return s;
  if (Status s = target("atlas", atlas_w, atlas_h, output_format, atlas_); !s.ok()) return s;
  if (Status s = target("feedback ld", kLinearWidth, feedback_rows, GL_RGBA32UI, ld_feedback_); !s.ok())
    return s;
  if (Status s = target("ld max rows", kLinearWidth, linear_rows(std::size_t(feedback_rows)), GL_RGBA32UI,
                        ld_max_rows_);
      !s.ok())
    return s;
  if (Status s = target("ld max", 1, 1, GL_RGBA32UI, ld_max_); !s.ok()) return s;
  if (has_probes_) {
    if (Status s = target("probes", kLinearWidth, linear_rows(blocks * std::size_t(probe_rows_)),
                          output_format, probes_);
        !s.ok())
      return s;
    if (Status s = target("world-frame probes", kLinearWidth, linear_rows(blocks * std::size_t(probe_rows_)),
                          output_format, probes_world_);
        !s.ok())
      return s;
    // The four quarter-turn SH9 rotations (sh9_quarter_turn_rotation), one row each.
    std::vector<float> rotation(4 * 81);
    for (int turns = 0; turns < 4; ++turns) {
      const std::array<double, 81> m = sh9_quarter_turn_rotation(turns);
      for (int k = 0; k < 81; ++k) rotation[std::size_t(81 * turns + k)] = float(m[std::size_t(k)]);
    }
    sh_rotation_ = create_texture(gl_, GL_R32F, 81, 4);
    textures_.push_back(sh_rotation_);
    gl_.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    gl_.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, 81, 4, GL_RED, GL_FLOAT, rotation.data());
  }
  if (has_vector_) {
    vector_.width = atlas_w;
    vector_.height = atlas_h;
    for (GLuint& tex : vector_.textures) {
      tex = create_texture(gl_, output_format, atlas_w, atlas_h);
      textures_.push_back(tex);
    }
    Result<GLuint> fb = create_framebuffer(
        gl_, "vector irradiance",
        {vector_.textures[0], vector_.textures[1], vector_.textures[2], vector_.textures[3]},
        target_ == TargetFormat::bits32 ? "RGBA32UI" : fmt);
    if (!fb.ok()) return fb.status();
    vector_.framebuffer = fb.value();
    framebuffers_.push_back(fb.value());
  }
  std::size_t largest = std::size_t(atlas_w) * std::size_t(atlas_h);
  for (const Target* tg : {&ld_feedback_, &probes_})
    largest = std::max(largest, std::size_t(tg->width) * std::size_t(tg->height));
  largest = std::max(largest, std::size_t(b_partial_.width) * std::size_t(b_partial_.height));
  largest = std::max(largest, std::size_t(r_partial_.width) * std::size_t(r_partial_.height));
  readback_.assign(4 * largest, 0.0f);

  // ---- programs ----
  const std::string defines =
      "#version 300 es\n#define LINEAR_SHIFT " + std::to_string(kLinearShift) + "\n#define OUTPUT_BITS " +
      (target_ == TargetFormat::bits32 ? "1" : "0") + "\n#define GROUPS " + std::to_string(groups_) +
      "\n#define R_GROUPS " + std::to_string(r_groups_) + "\n#define N_MAX " + std::to_string(n_max_) +
      "\n#define PROBE_ROWS " + std::to_string(probe_rows_) + "\n#define VECTOR_ROWS " +
      std::to_string(vector_rows_) + "\n#define B_CHUNK " + std::to_string(kBChunk) + "\n#define B_CHUNKS " +
      std::to_string(b_chunks_) + "\n#define MAX_LIGHT " + glsl_float(kMaxLightValue) +
      "\n#define OUTPUT_MAX " + (target_ == TargetFormat::float16 ? "65504.0" : "3.4028234e38") + "\n";
  defines_ = defines;
  const std::string ld_upload = defines + "#define LD_IS_SIGNAL 0\n",
                    ld_signal = defines + "#define LD_IS_SIGNAL 1\n";
  for (auto [prog, head, name] : {std::tuple{&prog_b_, &ld_upload, "b.frag"},
                                  std::tuple{&prog_b_feedback_, &ld_signal, "b.frag (feedback)"}})
    if (Status s = make_program(name, *head, kBFrag, *prog, {"u_td_b", "u_block_info", "u_ld"},
                                int(blocks) * groups_ * b_chunks_);
        !s.ok())
      return s;
  for (auto [prog, parts, count, name] :
       {std::tuple{&prog_b_reduce_, b_chunks_, blocks * std::size_t(groups_), "reduce.frag (b)"},
        std::tuple{&prog_r_reduce_, groups_, slots * std::size_t(r_groups_), "reduce.frag (r)"}}) {
    const std::string head = defines + "#define PARTS " + std::to_string(parts) + "\n";
    if (Status s = make_program(name, head, kReduceFrag, *prog,
                                {"u_partial_red", "u_partial_green", "u_partial_blue"}, int(count));
        !s.ok())
      return s;
  }
  if (Status s = make_program("r.frag", defines, kRFrag, prog_r_,
                              {"u_t", "u_slot_info", "u_record_block", "u_b_red", "u_b_green", "u_b_blue"},
                              int(slots) * r_groups_ * groups_);
      !s.ok())
    return s;
  if (Status s = make_program(
          "atlas.frag", defines + "#define DRT 0\n", kAtlasFrag, prog_atlas_,
          {"u_ub", "u_ur", "u_texel_sample", "u_sample_info", "u_sample_slots", "u_sample_rows",
           "u_block_info", "u_b_red", "u_b_green", "u_b_blue", "u_r_red", "u_r_green", "u_r_blue"});
      !s.ok())
    return s;
  if (Status s = make_program("feedback.frag", defines, kFeedbackFrag, prog_feedback_,
                              {"u_ld_direct", "u_rho", "u_sample_info", "u_atlas", "u_ld_max"}, int(samples));
      !s.ok())
    return s;
  prog_feedback_.u_bound = gl_.glGetUniformLocation(prog_feedback_.id, "u_bound");
  u_bound_scale_ = gl_.glGetUniformLocation(prog_feedback_.id, "u_bound_scale");
  if (Status s = make_program("ld_max.frag (rows)", defines + "#define STAGE 1\n", kLdMaxFrag,
                              prog_ld_max_rows_, {"u_ld"}, int(samples));
      !s.ok())
    return s;
  if (Status s = make_program("ld_max.frag", defines + "#define STAGE 2\n", kLdMaxFrag, prog_ld_max_,
                              {"u_rows"}, feedback_rows);
      !s.ok())
    return s;
  if (has_probes_) {
    if (Status s =
            make_program("probes.frag", defines + "#define DRT 0\n", kProbesFrag, prog_probes_,
                         {"u_ubvol", "u_probe_response", "u_block_info", "u_block_slots", "u_slot_info",
                          "u_b_red", "u_b_green", "u_b_blue", "u_r_red", "u_r_green", "u_r_blue"},
                         int(blocks) * probe_rows_);
        !s.ok())
      return s;
    if (Status s = make_program("probes_world.frag", defines, kProbesWorldFrag, prog_probes_world_,
                                {"u_probes", "u_rotation", "u_block_info"}, int(blocks) * probe_rows_);
        !s.ok())
      return s;
  }
  if (has_vector_)
    if (Status s = make_program("vector.frag", defines + "#define DRT 0\n", kVectorFrag, prog_vector_,
                                {"u_ub_vec", "u_vector_response", "u_texel_sample", "u_sample_info",
                                 "u_sample_slots", "u_sample_rows", "u_block_info", "u_slot_info", "u_b_red",
                                 "u_b_green", "u_b_blue", "u_r_red", "u_r_green", "u_r_blue"});
        !s.ok())
      return s;
  gl_.glUseProgram(0);
  // The tiles each block's samples appear in: its own, plus neighbours' tiles whose padding
  // copies its edge texels (architecture.md §4), so that a changed block redraws all of them.
  {
    std::vector<std::vector<Rect>> tiles(blocks);
    for (std::size_t i = 0; i < blocks && !atlas.tile_origin_x.empty(); ++i)
      for (int f = 0; f < kFaceCount; ++f) {
        const int ox = atlas.tile_origin_x[i][std::size_t(f)], oy = atlas.tile_origin_y[i][std::size_t(f)];
        if (ox < 0 || oy < 0) continue;
        for (int y = oy; y < oy + atlas.tile; ++y)
          for (int x = ox; x < ox + atlas.tile; ++x) {
            const std::int32_t sample = texel_sample[std::size_t(y) * std::size_t(atlas_w) + std::size_t(x)];
            if (sample < 0) continue;
            std::vector<Rect>& list = tiles[std::size_t(sample_info[4 * std::size_t(sample)])];
            if (list.empty() || list.back().x != ox || list.back().y != oy)
              list.push_back(Rect{ox, oy, atlas.tile, atlas.tile});
          }
      }
    block_tile_begin_.assign(blocks + 1, 0);
    tile_rects_.clear();
    for (std::size_t i = 0; i < blocks; ++i) {
      std::vector<Rect>& list = tiles[i];
      // Row by row, tiles side by side merged into one rect: one draw (a viewport) each.
      std::sort(list.begin(), list.end(),
                [](const Rect& a, const Rect& b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
      list.erase(std::unique(list.begin(), list.end(),
                             [](const Rect& a, const Rect& b) { return a.x == b.x && a.y == b.y; }),
                 list.end());
      for (const Rect& r : list) {
        Rect* last = tile_rects_.size() > block_tile_begin_[i] ? &tile_rects_.back() : nullptr;
        if (last && last->y == r.y && last->h == r.h && last->x + last->w == r.x)
          last->w += r.w;
        else
          tile_rects_.push_back(r);
      }
      block_tile_begin_[i + 1] = std::uint32_t(tile_rects_.size());
    }
  }
  rects_.reserve(std::max({blocks, slots, tile_rects_.size()}) + 1);
  gl_.glGenVertexArrays(1, &vao_);  // desktop core profiles draw only with a VAO bound
  timer_ = std::make_unique<platform::GpuTimer>(gl_, gles_context, kScopeCount);
  return check("creating targets and programs");
}

void GlesLevelRuntime::draw(const Program& program, GLuint framebuffer, int width, int height,
                            std::initializer_list<GLuint> textures, std::span<const Rect> rects) {
  gl_.glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
  gl_.glViewport(0, 0, width, height);
  gl_.glUseProgram(program.id);
  GLenum unit = GL_TEXTURE0;
  for (GLuint t : textures) {
    gl_.glActiveTexture(unit++);
    gl_.glBindTexture(GL_TEXTURE_2D, t);
  }
  if (rects.empty()) {
    gl_.glDrawArrays(GL_TRIANGLES, 0, 3);
    return;
  }
  // A viewport per rect: the full-viewport triangle then covers just the rect, and
  // gl_FragCoord stays in window coordinates, so the shaders need no change.
  for (const Rect& r : rects) {
    gl_.glViewport(r.x, r.y, r.w, r.h);
    gl_.glDrawArrays(GL_TRIANGLES, 0, 3);
  }
}

std::span<const GlesLevelRuntime::Rect> GlesLevelRuntime::linear_rects(std::span<const std::uint8_t> flags,
                                                                       int per) {
  rects_.clear();
  const std::size_t n = flags.size();
  for (std::size_t i = 0; i < n;) {
    if (!flags[i]) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < n && flags[j]) ++j;
    const std::size_t first = i * std::size_t(per), last = j * std::size_t(per) - 1;
    const int row0 = int(first >> kLinearShift), row1 = int(last >> kLinearShift);
    rects_.push_back(Rect{0, row0, kLinearWidth, row1 - row0 + 1});
    i = j;
  }
  return rects_;
}

// TimedStage -> the timer scope of its passes; -1: the stage draws nothing of its own (the
// tiles are drawn by the atlas pass, c by the delta pass).
static int scope_of(TimedStage stage) {
  switch (stage) {
    case TimedStage::upload: return kUpload;
    case TimedStage::feedback: return kFeedback;
    case TimedStage::b: return kB;
    case TimedStage::r: return kR;
    case TimedStage::drt: return kDrt;
    case TimedStage::atlas: return kAtlas;
    case TimedStage::vector: return kVector;
    case TimedStage::probes: return kProbes;
    case TimedStage::clutter: return kClutter;
    case TimedStage::lightmap:
    case TimedStage::clutter_c:
    case TimedStage::count: break;
  }
  return -1;
}

void GlesLevelRuntime::timer_begin(TimedStage stage) {
  if (const int scope = scope_of(stage); scope >= 0) timer_->begin(scope);
}

void GlesLevelRuntime::timer_end(TimedStage stage) {
  if (const int scope = scope_of(stage); scope >= 0) timer_->end(scope);
}

void GlesLevelRuntime::timer_collect(BackendStageTimes& t) {
  t.upload = timer_->elapsed_ns(kUpload);
  t.feedback = timer_->elapsed_ns(kFeedback);
  t.b = timer_->elapsed_ns(kB);
  t.r = timer_->elapsed_ns(kR);
  t.atlas = timer_->elapsed_ns(kAtlas);
  t.probes = timer_->elapsed_ns(kProbes);
  t.vector = timer_->elapsed_ns(kVector);
  t.drt = timer_->elapsed_ns(kDrt);
  t.clutter = timer_->elapsed_ns(kClutter);
  timer_->reset();
}

Status GlesLevelRuntime::stage_begin() {
  if (timing()) timer_->reset();
  eval_ = Evaluation{};
  ld_source_ = ld_;
  feedback_source_ = ld_direct_;
  gl_.glDisable(GL_BLEND);
  gl_.glDisable(GL_DEPTH_TEST);
  gl_.glDisable(GL_SCISSOR_TEST);
  gl_.glBindVertexArray(vao_);
  return Status::success();
}

void GlesLevelRuntime::stage_end(bool ok) {
  gl_.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gl_.glUseProgram(0);
  gl_.glBindVertexArray(0);
  ld_source_ = ld_;
  feedback_source_ = ld_direct_;
  if (!ok) return;
  probes_world_current_ = false;
  if (eval_.feedback || catching_up()) return;  // skip_stats counts the updates
  ++stats_.frames;
  stats_.frames_partial += eval_.pass.b;
  stats_.blocks_b += eval_.blocks_b, stats_.slots_r += eval_.slots_r,
      stats_.blocks_redrawn += eval_.blocks_redrawn;
}

GlesSkipStats GlesLevelRuntime::skip_stats() const {
  GlesSkipStats s = stats_;
  const std::uint64_t skipped = evaluation_stats().evaluations_skipped;
  s.frames += skipped, s.frames_skipped = skipped;
  return s;
}

// Each pass runs over its changed items only while they are few (partial_fraction).
Status GlesLevelRuntime::stage_ld(std::span<const float> ld, const StageWork& work) {
  const Level& level = *level_;
  const std::size_t blocks = level.blocks.size(), slots = level.slots.size();
  const double fraction = double(options_.partial_fraction);
  const bool partial = !work.everything && 2 * work.block_count <= blocks &&
                       double(work.block_count) <= fraction * double(blocks);
  eval_.pass.b = partial;
  eval_.pass.r = partial && double(work.slot_count) <= fraction * double(slots);
  // With clutter the pipeline marks every tile (a delta reads other blocks' b).
  eval_.pass.atlas = partial && double(work.tile_count) <= fraction * double(blocks);
  eval_.blocks_b = work.block_count;
  eval_.slots_r = eval_.pass.r ? work.slot_count : slots;
  eval_.blocks_redrawn = eval_.pass.atlas ? work.tile_count : blocks;
  if (partial) {
    for (std::size_t i = 0; i < blocks; ++i)
      if (work.blocks[i])
        upload_linear(gl_, ld_, GL_RGB, GL_FLOAT, 3,
                      ld.data() + 3 * std::size_t(level.blocks[i].sample_offset),
                      level.blocks[i].sample_count, sizeof(float), level.blocks[i].sample_offset);
  } else {
    upload_linear(gl_, ld_, GL_RGB, GL_FLOAT, 3, ld.data(), level.sample_count, sizeof(float));
  }
  return check("uploading ld");
}

Status GlesLevelRuntime::check_texture_name(std::uint32_t texture, const char* who) const {
  if (texture != 0 && gl_.glIsTexture(texture) == GL_TRUE) return Status::success();
  return refused(std::string(who) + ": " + std::to_string(texture) +
                 " is not a texture name of this GL context");
}

Status GlesLevelRuntime::stage_ld_texture(std::uint32_t ld_texture) {
  if (Status s = check_texture_name(ld_texture, "update_from_texture"); !s.ok()) return s;
  ld_source_ = ld_texture;
  eval_.blocks_b = level_->blocks.size();
  eval_.slots_r = level_->slots.size();
  eval_.blocks_redrawn = level_->blocks.size();
  return Status::success();
}

Status GlesLevelRuntime::stage_albedo(std::span<const float> rho) {
  upload_linear(gl_, rho_, GL_RGB, GL_FLOAT, 3, rho.data(), level_->sample_count, sizeof(float));
  return check("uploading albedo");
}

// feedback.frag: ld = ld_direct + rho min(max(atlas, 0), bound). With ld on the GPU, bound =
// ld_max x bound_scale, ld_max from ld_max.frag's texel.
Status GlesLevelRuntime::draw_feedback(float bound, float bound_scale) {
  gl_.glUseProgram(prog_feedback_.id);
  gl_.glUniform1f(prog_feedback_.u_bound, bound);
  gl_.glUniform1f(u_bound_scale_, bound_scale);
  gl_.glBindSampler(0, ld_sampler_);  // u_ld_direct: the caller's texture reads texel by texel
  draw(prog_feedback_, ld_feedback_.framebuffer, ld_feedback_.width, ld_feedback_.height,
       {feedback_source_, rho_, sample_info_, atlas_.texture, ld_max_.texture});
  gl_.glBindSampler(0, 0);
  eval_.feedback = true;
  return check("feedback pass");
}

Status GlesLevelRuntime::stage_feedback(std::span<const float> ld_direct, float bound) {
  upload_linear(gl_, ld_direct_, GL_RGB, GL_FLOAT, 3, ld_direct.data(), level_->sample_count, sizeof(float));
  if (Status s = check("uploading ld_direct"); !s.ok()) return s;
  return draw_feedback(bound, 0.0f);
}

Status GlesLevelRuntime::stage_feedback_texture(std::uint32_t ld_texture, float bound_per_ld) {
  if (Status s = check_texture_name(ld_texture, "multi_bounce_step_from_texture"); !s.ok()) return s;
  gl_.glBindSampler(0, ld_sampler_);  // the largest ld, on the GPU
  draw(prog_ld_max_rows_, ld_max_rows_.framebuffer, ld_max_rows_.width, ld_max_rows_.height, {ld_texture});
  gl_.glBindSampler(0, 0);
  draw(prog_ld_max_, ld_max_.framebuffer, 1, 1, {ld_max_rows_.texture});
  if (Status s = check("ld max passes"); !s.ok()) return s;
  feedback_source_ = ld_texture;
  eval_.ld_max_on_gpu = true;
  return draw_feedback(0.0f, bound_per_ld);
}

Status GlesLevelRuntime::stage_b(const StageWork& work) {
  if (eval_.feedback)
    draw(prog_b_feedback_, b_partial_.framebuffer, b_partial_.width, b_partial_.height,
         {td_b_, block_info_, ld_feedback_.texture});
  else {
    gl_.glBindSampler(2, ld_sampler_);  // u_ld's unit (draw binds the textures in order)
    draw(prog_b_, b_partial_.framebuffer, b_partial_.width, b_partial_.height,
         {td_b_, block_info_, ld_source_},
         eval_.pass.b ? linear_rects(work.blocks, groups_ * b_chunks_) : std::span<const Rect>{});
    gl_.glBindSampler(2, 0);
  }
  draw(prog_b_reduce_, b_.framebuffer, b_.width, b_.height,
       {b_partial_.textures[0], b_partial_.textures[1], b_partial_.textures[2]},
       eval_.pass.b ? linear_rects(work.blocks, groups_) : std::span<const Rect>{});
  return check("b pass (Td_b ld)");
}

Status GlesLevelRuntime::stage_r(const StageWork& work) {
  if (eval_.solved) return Status::success();  // r_ holds the solve's last application's r
  if (level_->slots.empty() || (eval_.pass.r && linear_rects(work.slots, 1).empty()))
    return Status::success();
  draw(prog_r_, r_partial_.framebuffer, r_partial_.width, r_partial_.height,
       {t_, slot_info_, record_block_, b_.textures[0], b_.textures[1], b_.textures[2]},
       eval_.pass.r ? linear_rects(work.slots, r_groups_ * groups_) : std::span<const Rect>{});
  draw(prog_r_reduce_, r_.framebuffer, r_.width, r_.height,
       {r_partial_.textures[0], r_partial_.textures[1], r_partial_.textures[2]},
       eval_.pass.r ? linear_rects(work.slots, r_groups_) : std::span<const Rect>{});
  return check("r pass (Tb_r b)");
}

// The clutter feedback reads the clutter atlas of the last evaluation, which stays in place
// until stage_clutter_lightmap: the c pass runs with the deltas (GlesDrt::run_scene).
Status GlesLevelRuntime::stage_clutter_c(ClutterCSource source, const ClutterFeedback& feedback) {
  eval_.clutter_feedback = source == ClutterCSource::feedback;
  eval_.clutter = feedback;
  return Status::success();
}

Status GlesLevelRuntime::stage_deltas(const StageWork&) {
  // The ld b.frag read (the gather's x_s): the feedback pass's, or the upload or caller's texture.
  const GlesDrtLd ld{eval_.feedback ? ld_feedback_.texture : ld_source_, eval_.feedback, ld_sampler_};
  drt_->run_scene(b_.textures, ld, eval_.clutter_feedback, eval_.clutter,
                  eval_.ld_max_on_gpu ? ld_max_.texture : 0, eval_.solved);
  return check("DRT pass (c = Td_c clutter_ld, delta = dUb b + dUc c + Ht x_t - Hs x_s)");
}

Status GlesLevelRuntime::stage_atlas(const StageWork& work) {
  rects_.clear();
  // With the camera skip (work.atlas) the visible blocks' rectangles, however many; else the
  // changed tiles' while they are few (eval_.pass).
  const bool camera = !work.atlas.empty();
  const std::span<const std::uint8_t> flags = camera ? work.atlas : work.tiles;
  atlas_partial_ = camera ? work.atlas_count < work.atlas.size() : eval_.pass.atlas;
  if (camera) eval_.blocks_redrawn = work.atlas_count;
  if (atlas_partial_)
    for (std::size_t i = 0; i < flags.size(); ++i)
      if (flags[i])
        rects_.insert(rects_.end(), tile_rects_.begin() + block_tile_begin_[i],
                      tile_rects_.begin() + block_tile_begin_[i + 1]);
  if (atlas_partial_ && rects_.empty()) return Status::success();  // nothing visible changed
  if (drt_)
    draw(prog_atlas_drt_, atlas_.framebuffer, atlas_.width, atlas_.height,
         {ub_, ur_, texel_sample_, sample_info_, sample_slots_, sample_rows_, block_info_, b_.textures[0],
          b_.textures[1], b_.textures[2], r_.textures[0], r_.textures[1], r_.textures[2],
          drt_->delta_texture()},
         atlas_partial_ ? std::span<const Rect>(rects_) : std::span<const Rect>{});
  else
    draw(prog_atlas_, atlas_.framebuffer, atlas_.width, atlas_.height,
         {ub_, ur_, texel_sample_, sample_info_, sample_slots_, sample_rows_, block_info_, b_.textures[0],
          b_.textures[1], b_.textures[2], r_.textures[0], r_.textures[1], r_.textures[2]},
         atlas_partial_ ? std::span<const Rect>(rects_) : std::span<const Rect>{});
  return check("atlas pass (Ub b + Ur r, padding)");
}

// The same tiles as the atlas (rects_ still holds them).
Status GlesLevelRuntime::stage_vector(const StageWork&) {
  if (!has_vector_ || (atlas_partial_ && rects_.empty())) return Status::success();
  const std::span<const Rect> rects =
      atlas_partial_ ? std::span<const Rect>(rects_) : std::span<const Rect>{};
  if (drt_ && drt_->vector_delta_texture())
    draw(prog_vector_drt_, vector_.framebuffer, vector_.width, vector_.height,
         {ub_vec_, vector_response_, texel_sample_, sample_info_, sample_slots_, sample_rows_, block_info_,
          slot_info_, b_.textures[0], b_.textures[1], b_.textures[2], r_.textures[0], r_.textures[1],
          r_.textures[2], drt_->vector_delta_texture()},
         rects);
  else
    draw(prog_vector_, vector_.framebuffer, vector_.width, vector_.height,
         {ub_vec_, vector_response_, texel_sample_, sample_info_, sample_slots_, sample_rows_, block_info_,
          slot_info_, b_.textures[0], b_.textures[1], b_.textures[2], r_.textures[0], r_.textures[1],
          r_.textures[2]},
         rects);
  return check("vector irradiance pass (Ub_vec b + Ur_vec r)");
}

Status GlesLevelRuntime::stage_probes(const StageWork& work) {
  if (level_->blocks.empty()) return Status::success();
  const std::span<const Rect> rects =
      eval_.pass.atlas ? linear_rects(work.tiles, probe_rows_) : std::span<const Rect>{};
  if (drt_ && drt_->probe_delta_texture())
    draw(prog_probes_drt_, probes_.framebuffer, probes_.width, probes_.height,
         {ubvol_, probe_response_, block_info_, block_slots_, slot_info_, b_.textures[0], b_.textures[1],
          b_.textures[2], r_.textures[0], r_.textures[1], r_.textures[2], drt_->probe_delta_texture()},
         rects);
  else
    draw(prog_probes_, probes_.framebuffer, probes_.width, probes_.height,
         {ubvol_, probe_response_, block_info_, block_slots_, slot_info_, b_.textures[0], b_.textures[1],
          b_.textures[2], r_.textures[0], r_.textures[1], r_.textures[2]},
         rects);
  return check("probe pass (Ubvol b + Urvol r)");
}

Status GlesLevelRuntime::stage_clutter_lightmap() {  // DRT §4.3
  drt_->run_clutter(b_.textures);
  return check("clutter atlas pass (Uc Vc b + direct)");
}

std::uint32_t GlesLevelRuntime::output_texture(BackendOutput output) const {
  switch (output) {
    case BackendOutput::atlas: return atlas_.texture;
    case BackendOutput::vector0: return vector_texture(0);
    case BackendOutput::vector1: return vector_texture(1);
    case BackendOutput::vector2: return vector_texture(2);
    case BackendOutput::vector3: return vector_texture(3);
    case BackendOutput::clutter_atlas: return clutter_texture();
    case BackendOutput::count: break;
  }
  return 0;
}

GlesLevelRuntime::LinearLayout GlesLevelRuntime::ld_layout() const {
  return {kLinearWidth, linear_rows(level_->sample_count)};
}

static_assert(int(TargetFormat::float32) == 0 && int(TargetFormat::float16) == 1 &&
                  int(TargetFormat::bits32) == 2,
              "output_texture_format: modrt.h's format codes");

Result<std::uint32_t> GlesLevelRuntime::world_probe_texture() {
  if (!has_probes_)
    return Status::error(ErrorCode::invalid_argument,
                         "gles: no probes (the dictionary has none or GlesRuntimeOptions::probes is off)");
  if (!updated()) return Status::error(ErrorCode::invalid_argument, "gles: no update has run yet");
  if (!probes_world_current_) {  // one pass per update, on request
    gl_.glDisable(GL_BLEND);
    gl_.glDisable(GL_DEPTH_TEST);
    gl_.glDisable(GL_SCISSOR_TEST);
    gl_.glBindVertexArray(vao_);
    draw(prog_probes_world_, probes_world_.framebuffer, probes_world_.width, probes_world_.height,
         {probes_.texture, sh_rotation_, block_info_});
    gl_.glBindFramebuffer(GL_FRAMEBUFFER, 0);
    gl_.glUseProgram(0);
    gl_.glBindVertexArray(0);
    if (Status s = check("world-frame probe pass"); !s.ok()) return s;
    probes_world_current_ = true;
  }
  return std::uint32_t(probes_world_.texture);
}

Status GlesLevelRuntime::read_target(GLuint framebuffer, int attachment, int width, int height, bool bits) {
  gl_.glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
  gl_.glReadBuffer(GLenum(GL_COLOR_ATTACHMENT0 + attachment));
  gl_.glPixelStorei(GL_PACK_ALIGNMENT, 4);
  // RGBA32UI targets hold float bit patterns: reading them as unsigned ints into float
  // storage yields the floats exactly.
  if (bits)
    gl_.glReadPixels(0, 0, width, height, GL_RGBA_INTEGER, GL_UNSIGNED_INT, readback_.data());
  else
    gl_.glReadPixels(0, 0, width, height, GL_RGBA, GL_FLOAT, readback_.data());
  gl_.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return check("reading back a render target");
}

Status GlesLevelRuntime::read_signal3(const Signal3& s, int groups, std::size_t items, std::size_t modes,
                                      std::span<float> out) {
  if (!updated()) return refused("read before the first update");
  for (int c = 0; c < 3; ++c) {
    if (Status st = read_target(s.framebuffer, c, s.width, s.height, true); !st.ok()) return st;
    for (std::size_t i = 0; i < items; ++i)
      for (std::size_t k = 0; k < modes; ++k)
        out[3 * modes * i + 3 * k + std::size_t(c)] =
            readback_[4 * (i * std::size_t(groups) + k / 4) + k % 4];
  }
  return Status::success();
}

Status GlesLevelRuntime::read_b(std::span<float> b) {
  if (b.size() != sizes().b) return wrong_size("b", b.size(), sizes().b);
  return read_signal3(b_, groups_, level_->blocks.size(), level_->kb, b);
}

Status GlesLevelRuntime::read_r(std::span<float> r) {
  if (r.size() != sizes().r) return wrong_size("r", r.size(), sizes().r);
  if (level_->slots.empty()) return Status::success();
  return read_signal3(r_, r_groups_, level_->slots.size(), level_->kr, r);
}

// The readbacks (a renderer samples the textures instead).
Status GlesLevelRuntime::read_output(StageOutput output, std::span<float> out) {
  const bool bits = target_ == TargetFormat::bits32;
  const std::vector<std::uint32_t>& texel = level_->atlas.sample_texel;
  switch (output) {
    case StageOutput::atlas:
    case StageOutput::lightmap: {
      if (out.empty()) return Status::success();
      if (Status s = read_target(atlas_.framebuffer, 0, atlas_.width, atlas_.height, bits); !s.ok()) return s;
      if (output == StageOutput::atlas)
        for (std::size_t i = 0; i < out.size() / 3; ++i)
          for (std::size_t c = 0; c < 3; ++c) out[3 * i + c] = readback_[4 * i + c];
      else
        for (std::size_t s = 0; s < texel.size(); ++s)
          for (std::size_t c = 0; c < 3; ++c) out[3 * s + c] = readback_[4 * std::size_t(texel[s]) + c];
      return Status::success();
    }
    case StageOutput::probes:
      if (Status s = read_target(probes_.framebuffer, 0, probes_.width, probes_.height, bits); !s.ok())
        return s;
      for (std::size_t i = 0; i < out.size() / 3; ++i)
        for (std::size_t c = 0; c < 3; ++c) out[3 * i + c] = readback_[4 * i + c];
      return Status::success();
    case StageOutput::vector_lightmap:
      if (!has_vector_) return refused("no vector irradiance (GlesRuntimeOptions::vector_irradiance is off)");
      for (int i = 0; i < 4; ++i) {
        if (Status s = read_target(vector_.framebuffer, i, vector_.width, vector_.height, bits); !s.ok())
          return s;
        for (std::size_t s = 0; s < texel.size(); ++s)
          for (std::size_t c = 0; c < 3; ++c)
            out[3 * (4 * s + std::size_t(i)) + c] = readback_[4 * std::size_t(texel[s]) + c];
      }
      return Status::success();
    case StageOutput::clutter_lightmap:
      if (Status s = drt_->read_clutter_lightmap(out); !s.ok()) return s;
      return check("reading back the clutter atlas");
    case StageOutput::clutter_vector_lightmap: {
      gl_.glDisable(GL_BLEND);
      gl_.glDisable(GL_DEPTH_TEST);
      gl_.glDisable(GL_SCISSOR_TEST);
      gl_.glBindVertexArray(vao_);
      const Status s = drt_->read_clutter_vector_lightmap(b_.textures, out);
      gl_.glUseProgram(0);
      gl_.glBindVertexArray(0);
      if (!s.ok()) return s;
      return check("rendering and reading back the clutter's vector irradiance");
    }
  }
  return Status::success();
}

Status GlesLevelRuntime::make_program(const char* name, const std::string& head, const char* fragment,
                                      Program& out, std::initializer_list<const char*> samplers, int count) {
  Result<GLuint> p =
      build_program(gl_, name, {"#version 300 es\n", kFullscreenVert}, {head.c_str(), kCommon, fragment});
  if (!p.ok()) return p.status();
  out.id = p.value();
  programs_.push_back(p.value());
  gl_.glUseProgram(out.id);
  assign_sampler_units(gl_, out.id, samplers);
  if (count >= 0) set_int(gl_, out.id, "u_count", count);
  return Status::success();
}

// The level passes that add a delta, built with DRT 1 on first use, and the DRT passes.
Status GlesLevelRuntime::stage_clutter_set(const DrtOperators* drt) {
  if (!drt) {
    drt_.reset();
    return Status::success();
  }
  auto drt_program = [&](const char* name, const char* fragment, Program& out,
                         std::initializer_list<const char*> samplers, int count) -> Status {
    if (out.id) return Status::success();
    return make_program(name, defines_ + "#define DRT 1\n", fragment, out, samplers, count);
  };
  if (Status s = drt_program(
          "atlas.frag (DRT)", kAtlasFrag, prog_atlas_drt_,
          {"u_ub", "u_ur", "u_texel_sample", "u_sample_info", "u_sample_slots", "u_sample_rows",
           "u_block_info", "u_b_red", "u_b_green", "u_b_blue", "u_r_red", "u_r_green", "u_r_blue", "u_delta"},
          -1);
      !s.ok())
    return s;
  if (has_vector_)
    if (Status s =
            drt_program("vector.frag (DRT)", kVectorFrag, prog_vector_drt_,
                        {"u_ub_vec", "u_vector_response", "u_texel_sample", "u_sample_info", "u_sample_slots",
                         "u_sample_rows", "u_block_info", "u_slot_info", "u_b_red", "u_b_green", "u_b_blue",
                         "u_r_red", "u_r_green", "u_r_blue", "u_vector_delta"},
                        -1);
        !s.ok())
      return s;
  if (has_probes_)
    if (Status s = drt_program(
            "probes.frag (DRT)", kProbesFrag, prog_probes_drt_,
            {"u_ubvol", "u_probe_response", "u_block_info", "u_block_slots", "u_slot_info", "u_b_red",
             "u_b_green", "u_b_blue", "u_r_red", "u_r_green", "u_r_blue", "u_probe_delta"},
            int(level_->blocks.size()) * probe_rows_);
        !s.ok())
      return s;
  gl_.glUseProgram(0);
  GlesDrtSetup setup;
  setup.defines = &defines_;
  setup.operator_format = operator_format_;
  setup.output_format = output_format_;
  setup.output_format_name = target_format_name(target_);
  setup.output_bits = target_ == TargetFormat::bits32;
  setup.max_texture_size = max_texture_size_;
  setup.vector = has_vector_;
  setup.probe_count = has_probes_ ? level_->blocks.size() * std::size_t(probe_rows_ / 9) : 0;
  Result<std::unique_ptr<GlesDrt>> created = GlesDrt::create(gl_, *level_, *drt, setup);
  if (!created.ok()) return created.status();
  if (Status s = check("creating the DRT passes"); !s.ok()) return s;
  drt_ = std::move(created).value();
  return Status::success();
}

Status GlesLevelRuntime::stage_clutter_light(std::span<const float> clutter_ld,
                                             std::span<const float> clutter_direct) {
  drt_->set_light(clutter_ld, clutter_direct);
  return check("uploading the clutter light");
}

Status GlesLevelRuntime::stage_clutter_albedo(std::span<const float> rho_c) {
  drt_->set_albedo(rho_c);
  return check("uploading the clutter albedo");
}

GLuint GlesLevelRuntime::clutter_texture() const { return drt_ ? drt_->clutter_texture() : 0; }

TextureSize GlesLevelRuntime::clutter_atlas_size() const {
  return drt_ ? TextureSize{drt_->clutter_width(), drt_->clutter_height()} : TextureSize{};
}

std::array<int, 2> GlesLevelRuntime::clutter_atlas_texel(std::size_t object, std::uint32_t t) const {
  return drt_ ? drt_->clutter_texel(object, t) : std::array<int, 2>{-1, -1};
}

}  // namespace modrt::gles
