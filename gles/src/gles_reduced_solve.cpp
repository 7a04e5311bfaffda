// SPDX-License-Identifier: MIT
// GlesLevelRuntime's converged multi-bounce (staged_backend.h's stage_solve; core's
// reduced_feedback.h, issue 20): the iteration x <- c + G x of core's ReducedSolver as fragment
// passes (reduced_solve.frag) over b-shaped signals, r = Tb->r x by the runtime's r pass. The
// GPU cannot stop on a residual it does not read back, so every solve starts from b0 and runs
// reduced_solve_iterations's a-priori count; with timing on the last step's residual is read
// back too (one texel).
#include <algorithm>
#include <cmath>
#include <string>

#include "gl_objects.h"
#include "gles_drt.h"
#include "modrt/gles/gles_level_runtime.h"

namespace modrt::gles {

extern const char* const kCommon;
extern const char* const kFullscreenVert;
extern const char* const kReduceFrag;
extern const char* const kReducedSolveFrag;

namespace {

// Texels of one item's per-channel matrix (row_groups x col_groups blocks of 4 x 4, 3 channels,
// 4 texels each).
std::size_t channel_block_texels(int row_groups, int col_groups) {
  return std::size_t(row_groups) * std::size_t(col_groups) * 12;
}

// Packs item `item`'s per-channel matrix (ChannelMatrix: rows x cols, 3 channels) in 4 x 4
// blocks, reduced_solve.frag's layout: texel (((item * row_groups + go) * col_groups + gi) * 3 +
// channel) * 4 + j holds rows 4go..4go+3 of column 4gi + j. Entries beyond rows and cols stay 0.
void pack_channel_blocks(const ChannelMatrix& m, std::size_t item, int row_groups, int col_groups,
                         std::vector<float>& out) {
  for (std::uint32_t r = 0; r < m.rows; ++r)
    for (std::uint32_t k = 0; k < m.cols; ++k)
      for (std::size_t ch = 0; ch < 3; ++ch) {
        const std::size_t texel =
            (((item * std::size_t(row_groups) + r / 4) * std::size_t(col_groups) + k / 4) * 3 + ch) * 4 +
            k % 4;
        out[4 * texel + r % 4] = m.data[3 * (std::size_t(r) * m.cols + k) + ch];
      }
}

}  // namespace

Status GlesLevelRuntime::build_reduced_programs() {
  if (solve_.apply_program.id) return Status::success();
  const std::size_t blocks = level_->blocks.size();
  const int count = int(blocks) * groups_;
  auto program = [&](const char* name, const std::string& head, const char* fragment, Program& out,
                     std::initializer_list<const char*> samplers) {
    return make_program(name, head, fragment, out, samplers, count);
  };
  const std::string& d = defines_;
  if (Status s = program("reduced_solve.frag (c = P b0)", d + "#define STAGE 1\n", kReducedSolveFrag,
                         solve_.rhs_program, {"u_p", "u_b0_red", "u_b0_green", "u_b0_blue", "u_block_info"});
      !s.ok())
    return s;
  if (Status s = program("reduced_solve.frag (apply)", d + "#define STAGE 2\n#define PLAIN 0\n",
                         kReducedSolveFrag, solve_.apply_program,
                         {"u_b", "u_block_slots", "u_c_red", "u_c_green", "u_c_blue", "u_r_red", "u_r_green",
                          "u_r_blue", "u_block_info"});
      !s.ok())
    return s;
  if (Status s = program("reduced_solve.frag (apply, plain)", d + "#define STAGE 2\n#define PLAIN 1\n",
                         kReducedSolveFrag, solve_.apply_plain_program,
                         {"u_b", "u_block_slots", "u_c_red", "u_c_green", "u_c_blue", "u_r_red", "u_r_green",
                          "u_r_blue", "u_a", "u_x_red", "u_x_green", "u_x_blue", "u_block_info"});
      !s.ok())
    return s;
  if (Status s =
          program("reduced_solve.frag (residual)", d + "#define STAGE 3\n", kReducedSolveFrag,
                  solve_.residual_program,
                  {"u_new_red", "u_new_green", "u_new_blue", "u_old_red", "u_old_green", "u_old_blue"});
      !s.ok())
    return s;
  if (Status s = program(
          "reduced_solve.frag (clutter)", d + "#define STAGE 4\n", kReducedSolveFrag, solve_.clutter_program,
          {"u_w", "u_block_samples", "u_sample_index", "u_delta", "u_b0_red", "u_b0_green", "u_b0_blue"});
      !s.ok())
    return s;
  solve_.u_scale = gl_.glGetUniformLocation(solve_.clutter_program.id, "u_scale");
  // b* into b_: reduce.frag with one part is a copy of the three planes.
  if (Status s = program("reduce.frag (copy)", d + "#define PARTS 1\n", kReduceFrag, solve_.copy_program,
                         {"u_partial_red", "u_partial_green", "u_partial_blue"});
      !s.ok())
    return s;
  gl_.glUseProgram(0);
  return check("compiling the reduced solve's programs");
}

Status GlesLevelRuntime::upload_reduced_operators(const ReducedFeedback& op) {
  const std::size_t blocks = level_->blocks.size(), slots = level_->slots.size();
  const std::size_t block_texels = std::max<std::size_t>(blocks * channel_block_texels(groups_, groups_), 1);
  const std::size_t slot_texels = std::max<std::size_t>(slots * channel_block_texels(groups_, r_groups_), 1);
  auto texture = [&](const char* name, std::size_t texels, GLuint& tex) -> Status {
    const int rows = linear_rows(texels);
    if (rows > max_texture_size_)
      return Status::error(ErrorCode::resource_limit,
                           std::string("gles: the reduced solve's ") + name + " need a " +
                               std::to_string(kLinearWidth) + " x " + std::to_string(rows) +
                               " texture, over this context's GL_MAX_TEXTURE_SIZE " +
                               std::to_string(max_texture_size_) + ": use the CPU backend's converged solve");
    if (!tex) {
      tex = create_texture(gl_, GL_RGBA32F, kLinearWidth, rows);
      textures_.push_back(tex);
    }
    return Status::success();
  };
  if (Status s = texture("block matrices", block_texels, solve_.block_matrices); !s.ok()) return s;
  if (Status s = texture("slot matrices", slot_texels, solve_.slot_matrices); !s.ok()) return s;
  solve_.plain = !op.block_jacobi;
  const std::vector<ChannelMatrix>& per_block = solve_.plain ? op.A : op.P;
  solve_pack_.assign(4 * block_texels, 0.0f);
  for (std::size_t i = 0; i < per_block.size(); ++i)
    pack_channel_blocks(per_block[i], i, groups_, groups_, solve_pack_);
  upload_linear(gl_, solve_.block_matrices, GL_RGBA, GL_FLOAT, 4, solve_pack_.data(), block_texels,
                sizeof(float));
  solve_pack_.assign(4 * slot_texels, 0.0f);
  for (std::size_t s = 0; s < op.B.size(); ++s)
    pack_channel_blocks(op.B[s], s, groups_, r_groups_, solve_pack_);
  upload_linear(gl_, solve_.slot_matrices, GL_RGBA, GL_FLOAT, 4, solve_pack_.data(), slot_texels,
                sizeof(float));
  solve_.clutter = op.clutter.drt != nullptr;
  if (solve_.clutter)
    if (Status s = upload_reduced_clutter(op.clutter); !s.ok()) return s;
  solve_pack_ = {};  // only needed again for another albedo
  return check("uploading the reduced solve's operators");
}

Status GlesLevelRuntime::upload_reduced_clutter(const ReducedClutter& cl) {
  const std::size_t blocks = level_->blocks.size(), reached = cl.samples.size(), kb = level_->kb;
  const std::size_t w_texels = std::max<std::size_t>(reached * std::size_t(groups_) * 3, 1);
  const std::size_t index_texels = std::max<std::size_t>(reached, 1);
  for (auto [name, texels] :
       {std::pair{"clutter weights", w_texels}, std::pair{"clutter samples", index_texels}})
    if (linear_rows(texels) > max_texture_size_)
      return Status::error(ErrorCode::resource_limit,
                           std::string("gles: the reduced solve's ") + name + " need a " +
                               std::to_string(kLinearWidth) + " x " + std::to_string(linear_rows(texels)) +
                               " texture, over this context's GL_MAX_TEXTURE_SIZE " +
                               std::to_string(max_texture_size_) + ": use the CPU backend's converged solve");
  // w_p[k][channel] at texel (p GROUPS + k / 4) 3 + channel, component k % 4 (STAGE 4's layout).
  solve_pack_.assign(4 * w_texels, 0.0f);
  for (std::size_t p = 0; p < reached; ++p)
    for (std::size_t k = 0; k < kb; ++k)
      for (std::size_t ch = 0; ch < 3; ++ch)
        solve_pack_[4 * ((p * std::size_t(groups_) + k / 4) * 3 + ch) + k % 4] = cl.w[3 * (kb * p + k) + ch];
  std::vector<std::int32_t> ranges(4 * blocks, 0), index(4 * index_texels, 0);
  for (std::size_t p = 0; p < reached; ++p) {
    const std::size_t blk = cl.sample_block[p];
    if (ranges[4 * blk + 1] == 0) ranges[4 * blk] = std::int32_t(p);  // sample_block is ascending
    ++ranges[4 * blk + 1];
    index[4 * p] = std::int32_t(cl.samples[p]);
  }
  auto table = [&](GLuint& tex, GLenum format, std::size_t texels) {
    if (tex) return;
    tex = create_texture(gl_, format, kLinearWidth, linear_rows(texels));
    textures_.push_back(tex);
  };
  // Sized for this clutter; a later clutter with more reached samples makes new ones (w holds
  // GROUPS x 3 texels per sample index texel, so its rows grow whenever the index's do).
  if (solve_.w && linear_rows(w_texels) > solve_.w_rows) solve_.w = solve_.sample_index = 0;
  table(solve_.w, GL_RGBA32F, w_texels);
  table(solve_.sample_index, GL_RGBA32I, index_texels);
  table(solve_.block_samples, GL_RGBA32I, blocks);
  solve_.w_rows = std::max(solve_.w_rows, linear_rows(w_texels));
  upload_linear(gl_, solve_.w, GL_RGBA, GL_FLOAT, 4, solve_pack_.data(), w_texels, sizeof(float));
  upload_linear(gl_, solve_.sample_index, GL_RGBA_INTEGER, GL_INT, 4, index.data(), index_texels,
                sizeof(std::int32_t));
  upload_linear(gl_, solve_.block_samples, GL_RGBA_INTEGER, GL_INT, 4, ranges.data(), blocks,
                sizeof(std::int32_t));
  return check("uploading the reduced solve's clutter terms");
}

Status GlesLevelRuntime::stage_solve(const ReducedFeedback& op, ReducedSolver&, std::span<float>, bool warm,
                                     const ReducedSolveSettings& settings, ReducedSolveReport& report) {
  // A cold solve follows every new albedo (StagedBackend rebuilds op and clears warm).
  if (Status s = build_reduced_programs(); !s.ok()) return s;
  if (!warm)
    if (Status s = upload_reduced_operators(op); !s.ok()) return s;
  const int k = reduced_solve_iterations(op.contraction, settings.tolerance, settings.max_iterations);
  // c = P b0 once (the plain iteration's c is b0, which b_ holds until the copy below); with
  // clutter c = P (b0 + s t) of each step's DRT deltas, and the clutter's c from c0.
  const bool clutter = solve_.clutter && drt_ != nullptr;
  const auto rhs = [&](const Signal3& from) {
    if (solve_.plain) return &from;
    draw(solve_.rhs_program, solve_.rhs.framebuffer, solve_.rhs.width, solve_.rhs.height,
         {solve_.block_matrices, from.textures[0], from.textures[1], from.textures[2], block_info_});
    return static_cast<const Signal3*>(&solve_.rhs);
  };
  const Signal3* c = clutter ? nullptr : rhs(b_);
  if (clutter) drt_->solve_start();
  const Signal3* in = &b_;  // x0 = b0
  for (int it = 0; it < k; ++it) {
    if (clutter) {
      // delta and the next c from (x, c) of this step, then u = b0 + s sum w delta, c = P u.
      drt_->solve_step(in->textures, op.clutter.scale);
      gl_.glUseProgram(solve_.clutter_program.id);
      gl_.glUniform1f(solve_.u_scale, op.clutter.scale);
      draw(solve_.clutter_program, solve_.u.framebuffer, solve_.u.width, solve_.u.height,
           {solve_.w, solve_.block_samples, solve_.sample_index,
            drt_->has_delta() ? drt_->delta_texture() : 0, b_.textures[0], b_.textures[1], b_.textures[2]});
      c = rhs(solve_.u);
    }
    // r = Tb->r x (the r pass over x's planes), then x' = c + G x.
    draw(prog_r_, r_partial_.framebuffer, r_partial_.width, r_partial_.height,
         {t_, slot_info_, record_block_, in->textures[0], in->textures[1], in->textures[2]});
    draw(prog_r_reduce_, r_.framebuffer, r_.width, r_.height,
         {r_partial_.textures[0], r_partial_.textures[1], r_partial_.textures[2]});
    Signal3& out = solve_.x[std::size_t(it % 2)];
    if (solve_.plain)
      draw(solve_.apply_plain_program, out.framebuffer, out.width, out.height,
           {solve_.slot_matrices, block_slots_, c->textures[0], c->textures[1], c->textures[2],
            r_.textures[0], r_.textures[1], r_.textures[2], solve_.block_matrices, in->textures[0],
            in->textures[1], in->textures[2], block_info_});
    else
      draw(solve_.apply_program, out.framebuffer, out.width, out.height,
           {solve_.slot_matrices, block_slots_, c->textures[0], c->textures[1], c->textures[2],
            r_.textures[0], r_.textures[1], r_.textures[2], block_info_});
    if (it + 1 == k && timing())
      draw(solve_.residual_program, solve_.residual.framebuffer, 1, 1,
           {out.textures[0], out.textures[1], out.textures[2], in->textures[0], in->textures[1],
            in->textures[2]});
    in = &out;
  }
  draw(solve_.copy_program, b_.framebuffer, b_.width, b_.height,
       {in->textures[0], in->textures[1], in->textures[2]});
  if (Status s = check("reduced solve passes (x = c + G x)"); !s.ok()) return s;
  eval_.solved = true;

  report = ReducedSolveReport{};
  report.iterations = k;
  report.blocks_applied = std::uint64_t(k) * level_->blocks.size();  // every pass draws every block
  const double q = std::max(op.contraction, 1e-12);
  const double a_priori = std::pow(q, double(k));
  if (timing()) {
    if (Status s = read_target(solve_.residual.framebuffer, 0, 1, 1, true); !s.ok()) return s;
    const float change = readback_[0], largest = readback_[1];
    report.residual = largest > 0.0f ? change / largest : 0.0f;
    report.error_bound = float(double(report.residual) * q / (1.0 - q));
    report.converged = report.error_bound <= settings.tolerance;
  } else {
    report.measured = false;
    report.residual = report.error_bound = float(a_priori);
    report.converged = a_priori <= double(settings.tolerance);
  }
  return Status::success();
}

}  // namespace modrt::gles
