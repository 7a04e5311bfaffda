// SPDX-License-Identifier: MIT
#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/feedback_policy.h"
#include "modrt/level_dirty.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <system_error>

#include "fp_env.h"
#include "modrt/cpu/kernels.h"
#include "modrt/reference_runtime.h"
#include "thread_pool.h"

namespace modrt::cpu {
namespace {

Status wrong_size(const char* what, std::size_t got, std::size_t expected) {
  return Status::error(ErrorCode::invalid_argument, std::string(what) + ": has " + std::to_string(got) +
                                                        " floats, expected " + std::to_string(expected));
}

double frobenius(const Matrix& m, const double* col_scale = nullptr) {
  double acc = 0.0;
  for (std::uint32_t r = 0; r < m.rows; ++r)
    for (std::uint32_t c = 0; c < m.cols; ++c) {
      const double v = double(m(r, c)) / (col_scale ? col_scale[c] : 1.0);
      acc += v * v;
    }
  return std::sqrt(acc);
}

// Row-major k x k products in double.
std::vector<double> matmul(const std::vector<double>& a, const std::vector<double>& b, std::size_t k) {
  std::vector<double> c(k * k, 0.0);
  for (std::size_t i = 0; i < k; ++i)
    for (std::size_t l = 0; l < k; ++l)
      for (std::size_t j = 0; j < k; ++j) c[i * k + j] += a[i * k + l] * b[l * k + j];
  return c;
}

// A^T diag(w)^2 A for the m x k matrix A (columns scaled by 1 / d when d is given):
// the k x k Gram matrix of A D^-1.
std::vector<double> gram(const Matrix& a, const double* d = nullptr) {
  const std::size_t k = a.cols;
  std::vector<double> g(k * k, 0.0);
  for (std::uint32_t r = 0; r < a.rows; ++r)
    for (std::size_t i = 0; i < k; ++i) {
      const double ai = a(r, std::uint32_t(i)) / (d ? d[i] : 1.0);
      for (std::size_t j = 0; j < k; ++j) g[i * k + j] += ai * a(r, std::uint32_t(j)) / (d ? d[j] : 1.0);
    }
  return g;
}

// A diag(d)^2 A^T... for the k x n matrix A with rows scaled by d: (D A)(D A)^T, k x k.
std::vector<double> gram_rows(const Matrix& a, const double* d) {
  const std::size_t k = a.rows;
  std::vector<double> g(k * k, 0.0);
  for (std::size_t i = 0; i < k; ++i)
    for (std::size_t j = 0; j < k; ++j) {
      double acc = 0.0;
      for (std::uint32_t c = 0; c < a.cols; ++c)
        acc += double(a(std::uint32_t(i), c)) * a(std::uint32_t(j), c);
      g[i * k + j] = acc * (d ? d[i] * d[j] : 1.0);
    }
  return g;
}

// An upper bound on the spectral radius of the k x k matrix x: rho(x) <= ||x^p||_inf^(1/p)
// for any p (every induced norm bounds it); p = 32 by repeated squaring, rescaled as it goes.
// Within a factor k^(1/32) of rho; a 1e-9 relative margin covers the double rounding.
double spectral_radius_bound(std::vector<double> x, std::size_t k) {
  auto inf_norm = [&] {
    double m = 0.0;
    for (std::size_t i = 0; i < k; ++i) {
      double row = 0.0;
      for (std::size_t j = 0; j < k; ++j) row += std::abs(x[i * k + j]);
      m = std::max(m, row);
    }
    return m;
  };
  double log_scale = 0.0;  // x = (original)^p / exp(log_scale)
  double p = 1.0;
  for (int it = 0; it < 5; ++it) {
    const double n = inf_norm();
    if (n == 0.0) return 0.0;
    for (double& v : x) v /= n;
    log_scale = 2.0 * (log_scale + std::log(n));
    x = matmul(x, x, k);
    p *= 2.0;
  }
  const double n = inf_norm();
  if (n == 0.0) return 0.0;
  return std::exp((std::log(n) + log_scale) / p) * (1.0 + 1e-9);
}

// The values the kernels read for m: m itself (float32 operators) or, given its half copy,
// those decoded into `decoded` (float16 operators): the skip norms are computed from these.
const Matrix& kernel_values(const Matrix& m, const std::uint16_t* half, Matrix& decoded) {
  if (!half) return m;
  decoded = Matrix(m.rows, m.cols);
  for (std::size_t i = 0; i < decoded.data.size(); ++i) decoded.data[i] = half_to_float(half[i]);
  return decoded;
}

bool same_bits(const float* a, const float* b, std::size_t n) {
  return std::memcmp(a, b, n * sizeof(float)) == 0;
}

// What phase 1 did with a block's b (CpuSkipStats).
enum BlockAction : std::uint8_t { kComputed, kKept, kDark };

}  // namespace

CpuLevelRuntime::CpuLevelRuntime(CpuLevelRuntime&&) noexcept = default;
CpuLevelRuntime& CpuLevelRuntime::operator=(CpuLevelRuntime&&) noexcept = default;
CpuLevelRuntime::~CpuLevelRuntime() = default;

// Every phase of every public call runs here: the flush-to-zero guard (fp_env.h) covers the
// calling thread for the whole loop and each worker for each of its tasks (the control
// register is per thread).
template <class F>
void CpuLevelRuntime::parallel_for(std::size_t count, F& f) const {
  const ScopedFlushDenormals flush(flush_denormals_);
  if (!pool_) {
    for (std::size_t i = 0; i < count; ++i) f(i, 0);
    return;
  }
  struct Task {
    F* f;
    bool flush;
  } task{&f, flush_denormals_};
  pool_->run(
      count,
      [](void* ctx, std::size_t i, int thread) {
        const Task& t = *static_cast<const Task*>(ctx);
        const ScopedFlushDenormals worker_flush(t.flush && thread != 0);
        (*t.f)(i, thread);
      },
      &task);
}

void CpuLevelRuntime::gemv(const OperatorRef& A, std::size_t rows, std::size_t cols, const float* planar,
                           float* out, bool accumulate) const {
  if (A.f16)
    gemv_rgb_f16(isa_, A.f16, rows, cols, cols, planar, cols, out, accumulate);
  else
    gemv_rgb(isa_, A.f32, rows, cols, cols, planar, cols, out, accumulate);
}

void CpuLevelRuntime::gemv_scatter(const OperatorRef& A, std::size_t rows, std::size_t cols,
                                   const std::int32_t* map, const float* planar, float* out) const {
  if (A.f16)
    gemv_rgb_scatter_f16(isa_, A.f16, rows, cols, cols, map, planar, cols, out);
  else
    gemv_rgb_scatter(isa_, A.f32, rows, cols, cols, map, planar, cols, out);
}

void CpuLevelRuntime::gemv_masked(const OperatorRef& A, std::size_t rows, std::size_t cols,
                                  const std::int32_t* map, const float* planar, float* out) const {
  if (A.f16)
    gemv_rgb_masked_f16(isa_, A.f16, rows, cols, cols, map, planar, cols, out);
  else
    gemv_rgb_masked(isa_, A.f32, rows, cols, cols, map, planar, cols, out);
}

// Points every OperatorRef at the operator's floats (float32) or at its half copy in half_
// (float16, converted here). Needs vector_ready_.
Status CpuLevelRuntime::prepare_operators(OperatorStorage storage) {
  const Level& level = *level_;
  const Dictionary& dict = *dict_;
  operators_ = storage;
  enum Owner { kShape, kInterface, kRecord, kFace };
  struct Item {
    const Matrix* m;
    OperatorRef* ref;
    const char* what;
    Owner owner;
    std::size_t index;  // of the shape, record or face
  };
  std::vector<Item> items;
  std::vector<std::uint8_t> shape_used(operator_set_count(dict, level), 0);
  for (const LevelBlock& blk : level.blocks) shape_used[operator_set(dict, blk)] = 1;
  shape_ops_.assign(operator_set_count(dict, level), ShapeRefs{});
  for (std::size_t sh = 0; sh < operator_set_count(dict, level); ++sh) {
    if (!shape_used[sh]) continue;
    const ShapeOperators& op = operator_set_at(dict, level, sh);
    items.push_back({&op.Td_b, &shape_ops_[sh].td_b, "Td_b", kShape, sh});
    items.push_back({&op.Ub, &shape_ops_[sh].ub, "Ub", kShape, sh});
    if (sizes_.probes > 0) items.push_back({&op.Ubvol, &shape_ops_[sh].ubvol, "Ubvol", kShape, sh});
    if (vector_ready_) items.push_back({&op.Ub_vec, &shape_ops_[sh].ub_vec, "Ub_vec", kShape, sh});
  }
  if (!level.slots.empty()) items.push_back({&dict.interfaces.Ur, &ur_op_, "Ur", kInterface, 0});
  record_ops_.assign(level.records.size(), OperatorRef{});
  for (std::size_t q = 0; q < level.records.size(); ++q)
    items.push_back({&level.records[q].T, &record_ops_[q], "T", kRecord, q});
  probe_ops_.assign(kFaceCount, OperatorRef{});
  vector_ops_.assign(kFaceCount, OperatorRef{});
  for (std::size_t f = 0; f < std::size_t(kFaceCount); ++f) {
    if (sizes_.probes > 0 && !level.probe_response[f].empty())
      items.push_back({&level.probe_response[f], &probe_ops_[f], "probe response", kFace, f});
    if (vector_ready_ && !level.vector_response[f].empty())
      items.push_back({&level.vector_response[f], &vector_ops_[f], "vector response", kFace, f});
  }
  std::size_t total = 0;
  for (const Item& it : items) total += it.m->data.size();
  if (storage == OperatorStorage::float32) {
    for (const Item& it : items) it.ref->f32 = it.m->data.data();
    operator_bytes_ = total * sizeof(float);
    return Status::success();
  }
  half_.assign(total, 0);
  std::size_t offset = 0;
  for (const Item& it : items) {
    const std::size_t count = it.m->data.size();
    const std::size_t bad = float_to_half(it.m->data.data(), count, half_.data() + offset);
    if (bad < count) {
      const std::string index = std::to_string(it.index);
      const std::string where = it.owner == kShape    ? "shape " + index + " " + it.what
                                : it.owner == kRecord ? "record " + index + " (" + it.what + ")"
                                : it.owner == kFace   ? std::string(it.what) + " of face " + index
                                                      : std::string(it.what);
      char value[32];
      std::snprintf(value, sizeof value, "%g", double(it.m->data[bad]));
      return Status::error(ErrorCode::invalid_argument,
                           "cpu runtime: float16 operators: " + where + " value " + value + " at row " +
                               std::to_string(bad / it.m->cols) + ", column " +
                               std::to_string(bad % it.m->cols) + " exceeds float16 range (|v| <= 65504)");
    }
    it.ref->f16 = half_.data() + offset;
    offset += count;
  }
  operator_bytes_ = total * sizeof(std::uint16_t);
  return Status::success();
}

Result<CpuLevelRuntime> CpuLevelRuntime::create(const Level& level, const Dictionary& dict,
                                                const CpuRuntimeOptions& options) {
  const Isa isa = options.isa.value_or(active_isa());
  if (!isa_supported(isa))
    return Status::error(ErrorCode::invalid_argument, std::string("cpu runtime: ISA ") + isa_name(isa) +
                                                          " is not supported by this build or CPU");
  if (options.threads < 1 || options.threads > 256)
    return Status::error(ErrorCode::invalid_argument,
                         "cpu runtime: threads must be in [1, 256], got " + std::to_string(options.threads));
  if (Status s = check_level_operators(level, dict); !s.ok()) return s;

  CpuLevelRuntime rt;
  rt.level_ = &level;
  rt.dict_ = &dict;
  rt.isa_ = isa;
  rt.threads_ = options.threads;
  rt.flush_denormals_ = options.flush_denormals;
  rt.sizes_ = level_buffer_sizes(level, dict);
  for (const LevelBlock& blk : level.blocks)
    rt.max_block_samples_ = std::max<std::size_t>(rt.max_block_samples_, blk.sample_count);
  rt.b_.assign(rt.sizes_.b, 0.0f);
  rt.b_planar_.assign(rt.sizes_.b, 0.0f);
  for (const LevelBlock& blk : level.blocks) rt.block_kb_.push_back(block_kb(dict, level, blk));
  rt.r_.assign(rt.sizes_.r, 0.0f);
  rt.r_planar_.assign(rt.sizes_.r, 0.0f);
  rt.x_planar_.assign(rt.sizes_.b, 0.0f);
  rt.r_delta_.assign(rt.sizes_.r, 0.0f);
  rt.slot_touched_.assign(level.slots.size(), 0);
  rt.ld_planar_.assign(3 * rt.max_block_samples_ * std::size_t(options.threads), 0.0f);
  rt.rho_.assign(rt.sizes_.ld, 0.0f);
  rt.ld_feedback_.assign(rt.sizes_.ld, 0.0f);
  rt.work_items_.assign(level.blocks.size(), 0);
  {  // the level's transport graph, as every backend's skipping reads it (core's level_dirty.h)
    LevelDependencies deps = level_dependencies(level);
    rt.slot_record_begin_ = std::move(deps.slot_record_begin),
    rt.slot_records_ = std::move(deps.slot_records);
    rt.block_slot_begin_ = std::move(deps.block_slot_begin), rt.block_slots_ = std::move(deps.block_slots);
  }
  const std::size_t threads = std::size_t(options.threads), blocks = level.blocks.size(),
                    slots = level.slots.size();
  if (check_level_vector_operators(level, dict).ok()) {
    rt.vector_ready_ = true;
    rt.vector_rows_ = 4 * std::size_t(dict.interfaces.Ur.rows);
    rt.vector_row_map_.assign(rt.vector_rows_ * slots, -1);
    for (std::size_t s = 0; s < slots; ++s)
      for (std::size_t t = 0; t < level.slots[s].ur_row_to_sample.size(); ++t) {
        const std::int32_t sample = level.slots[s].ur_row_to_sample[t];
        if (sample >= 0)
          for (std::size_t i = 0; i < 4; ++i)
            rt.vector_row_map_[rt.vector_rows_ * s + 4 * t + i] = 4 * sample + std::int32_t(i);
      }
  }
  rt.build_padding_rows();
  if (Status s = rt.prepare_operators(options.operators); !s.ok()) return s;
  // Skipping: operator norms for the bounds (of the operators the kernels read: with float16,
  // the half-rounded values), and the per-block / per-slot / per-thread state.
  // D = diag(column norms of Ub) (about the singular values): b's large, cancelling high
  // modes are small in D b, and ||X Td_b|| <= ||X D^-1|| ||D Td_b|| for any operator X.
  const std::size_t kb = level.kb;
  Matrix decoded_ub, decoded_td_b, decoded;
  for (std::size_t sh = 0; sh < operator_set_count(dict, level); ++sh) {
    const ShapeRefs& refs = rt.shape_ops_[sh];
    const Matrix& Ub = kernel_values(operator_set_at(dict, level, sh).Ub, refs.ub.f16, decoded_ub);
    const Matrix& Td_b = kernel_values(operator_set_at(dict, level, sh).Td_b, refs.td_b.f16, decoded_td_b);
    const std::size_t kb_set = Ub.cols;  // kept kb apart in shape_d_ (the level's stride)
    std::vector<double> d(kb, 0.0);
    for (std::uint32_t r = 0; r < Ub.rows; ++r)
      for (std::size_t k = 0; k < kb_set; ++k)
        d[k] += double(Ub(r, std::uint32_t(k))) * Ub(r, std::uint32_t(k));
    for (double& v : d) v = std::max(std::sqrt(v), 1e-30);
    const std::vector<double> td_gram = gram_rows(Td_b, nullptr);
    // ||Ub Td_b||_2^2 = rho((Ub^T Ub)(Td_b Td_b^T)); ||D Td_b||_2^2 = rho(D Td_b Td_b^T D).
    rt.shape_ub_td_norm_.push_back(
        std::sqrt(spectral_radius_bound(matmul(gram(Ub), td_gram, kb_set), kb_set)));
    rt.shape_d_td_norm_.push_back(std::sqrt(spectral_radius_bound(gram_rows(Td_b, d.data()), kb_set)));
    rt.shape_d_.insert(rt.shape_d_.end(), d.begin(), d.end());
  }
  rt.ur_norm_ = std::sqrt(
      spectral_radius_bound(gram(kernel_values(dict.interfaces.Ur, rt.ur_op_.f16, decoded)), level.kr));
  rt.record_norm_.reserve(level.records.size());
  rt.record_d_norm_.reserve(level.records.size());
  for (std::size_t q = 0; q < level.records.size(); ++q) {
    const ResponseRecord& rec = level.records[q];
    const Matrix& T = kernel_values(rec.T, rt.record_ops_[q].f16, decoded);
    const std::size_t shape = operator_set(dict, level.blocks[rec.source_block]);
    rt.record_norm_.push_back(frobenius(T));
    rt.record_d_norm_.push_back(frobenius(T, rt.shape_d_.data() + kb * shape));
  }
  rt.block_action_.assign(blocks, kComputed);
  rt.b_changed_.assign(blocks, 1);
  rt.tile_written_.assign(blocks, 1);
  rt.r_changed_.assign(slots, 1);
  rt.slot_kept_.assign(slots, 0);
  rt.ld_delta_.assign(blocks, 0.0);
  rt.b_norm_.assign(blocks, 0.0);
  rt.b_d_norm_.assign(blocks, 0.0);
  rt.tile_bound_.assign(blocks, 0.0);
  rt.slot_rho_.assign(slots, 0.0);
  rt.slot_drift_.assign(slots, 0.0);
  rt.slot_close_.assign(slots, 0);
  rt.slot_records_computed_.assign(slots, 0);
  rt.slot_records_skipped_.assign(slots, 0);
  rt.ld_ref_.assign(rt.sizes_.ld, 0.0f);
  rt.ld_ref_max_.assign(blocks, 0.0f);
  rt.b_scratch_.assign(3 * std::size_t(level.kb) * threads, 0.0f);
  rt.r_scratch_.assign(3 * std::size_t(level.kr) * threads, 0.0f);
  if (Status s = rt.set_skip_options(options.skip); !s.ok()) return s;

  if (options.threads > 1) {
    try {
      rt.pool_ = std::make_unique<ThreadPool>(options.threads);
    } catch (const std::system_error& e) {
      return Status::error(ErrorCode::invalid_argument,
                           std::string("cpu runtime: cannot start threads: ") + e.what());
    }
  }
  return rt;
}

Status CpuLevelRuntime::evaluate(std::span<const float> ld, std::span<float> lightmap) {
  const Level& level = *level_;
  // SIMD check first; core's validation (which names the bad value) only when it fails.
  if (ld.size() != sizes_.ld || !finite_nonnegative(isa_, ld.data(), ld.size(), kMaxLightValue))
    if (Status s = validate_light_signal(ld, level.sample_count, "ld"); !s.ok()) return s;
  if (lightmap.size() != sizes_.lightmap) return wrong_size("lightmap", lightmap.size(), sizes_.lightmap);

  if (skip_.enabled) {
    auto b_phase = [&](std::size_t i, int thread) { skip_block_b(i, ld, thread); };
    parallel_for(level.blocks.size(), b_phase);
    auto lightmap_phase = [&](std::size_t i, int thread) { skip_block_lightmap(i, lightmap, thread); };
    parallel_for(level.blocks.size(), lightmap_phase);
    finish_skip_stats();
    skip_state_valid_ = true;
    last_lightmap_ = lightmap.data();
    return Status::success();
  }
  auto b_phase = [&](std::size_t i, int thread) { compute_block_b(i, ld, thread); };
  parallel_for(level.blocks.size(), b_phase);
  auto lightmap_phase = [&](std::size_t i, int) { compute_block_lightmap(i, lightmap); };
  parallel_for(level.blocks.size(), lightmap_phase);
  return Status::success();
}

Status CpuLevelRuntime::set_skip_options(const CpuSkipOptions& skip) {
  auto bad = [](float v) { return !(v >= 0.0f) || !std::isfinite(v); };
  if (bad(skip.ld_epsilon) || bad(skip.dark_ld) || bad(skip.record_epsilon) || skip.record_epsilon > 1.0f ||
      bad(skip.r_epsilon))
    return Status::error(
        ErrorCode::invalid_argument,
        "cpu runtime: skip options: ld_epsilon, dark_ld and r_epsilon must be finite and >= 0, "
        "record_epsilon in [0, 1]");
  if (skip.enabled && self_lightmap_.size() != sizes_.lightmap) {
    self_lightmap_.assign(sizes_.lightmap, 0.0f);
    slot_contribution_.assign(3 * std::size_t(dict_->interfaces.Ur.rows) * level_->slots.size(), 0.0f);
  }
  skip_ = skip;
  stats_ = CpuSkipStats{};
  skip_state_valid_ = false;
  last_lightmap_ = nullptr;
  return Status::success();
}

// Phase 1 with skipping (CpuSkipOptions (a), (b)) for block i.
void CpuLevelRuntime::skip_block_b(std::size_t i, std::span<const float> ld, int thread) {
  const LevelBlock& blk = level_->blocks[i];
  const std::size_t n = blk.sample_count, kb = level_->kb, kb_i = block_kb_[i];
  const float* l = ld.data() + 3 * std::size_t(blk.sample_offset);
  float* ref = ld_ref_.data() + 3 * std::size_t(blk.sample_offset);
  float* b = b_.data() + 3 * kb * i;
  float* bp = b_planar_.data() + 3 * kb * i;
  const bool force = !skip_state_valid_;
  const SignalChange change = signal_change(isa_, l, ref, 3 * n);
  const float m_all = change.max, d_all = change.max_diff;
  const double m2 = change.sum_sq, d2 = change.sum_sq_diff;
  if (m_all <= skip_.dark_ld) {  // (b) dark: b = 0, which is Td_b times an ld_ref of 0
    block_action_[i] = kDark;
    const bool was_zero = std::all_of(b, b + 3 * kb, [](float v) { return v == 0.0f; });
    if (!was_zero || force) {
      std::fill(b, b + 3 * kb, 0.0f);
      std::fill(bp, bp + 3 * kb, 0.0f);
    }
    if (ld_ref_max_[i] != 0.0f || force) std::fill(ref, ref + 3 * n, 0.0f);
    ld_ref_max_[i] = 0.0f;
    b_changed_[i] = !was_zero || force;
    b_norm_[i] = b_d_norm_[i] = 0.0;
    ld_delta_[i] = std::sqrt(m2);
    return;
  }
  if (!force && d_all <= skip_.ld_epsilon * ld_ref_max_[i]) {  // (a) keep b
    block_action_[i] = kKept;
    b_changed_[i] = 0;
    ld_delta_[i] = std::sqrt(d2);
    return;
  }
  block_action_[i] = kComputed;
  std::copy(l, l + 3 * n, ref);
  ld_ref_max_[i] = m_all;
  float* scratch = ld_planar_.data() + 3 * max_block_samples_ * std::size_t(thread);
  float* b_new = b_scratch_.data() + 3 * kb * std::size_t(thread);
  deinterleave_rgb(l, n, scratch, n);
  gemv(shape_ops_[operator_set(*dict_, blk)].td_b, kb_i, n, scratch, b_new, false);
  const bool changed = force || !same_bits(b_new, b, 3 * kb_i);  // past kb_i, b stays zero
  if (changed) {
    std::copy(b_new, b_new + 3 * kb_i, b);
    deinterleave_rgb(b, kb_i, bp, kb_i);
    const double* dk = shape_d_.data() + kb * operator_set(*dict_, blk);
    double n2 = 0.0, dn2 = 0.0;
    for (std::size_t k = 0; k < kb_i; ++k)
      for (std::size_t c = 0; c < 3; ++c) {
        const double v = b[3 * k + c];
        n2 += v * v;
        dn2 += v * v * dk[k] * dk[k];
      }
    b_norm_[i] = std::sqrt(n2);
    b_d_norm_[i] = std::sqrt(dn2);
  }
  b_changed_[i] = changed;
  ld_delta_[i] = 0.0;
}

// (c): w_q >= ||T_q b_source||_F, the smaller of two bounds.
double CpuLevelRuntime::record_weight(std::size_t rec, std::size_t src) const {
  return std::min(record_norm_[rec] * b_norm_[src], record_d_norm_[rec] * b_d_norm_[src]);
}

// Phase 2 with skipping (CpuSkipOptions (c), (d)) for block i: the r of its slots whose
// sources changed (records below the bound left out), then its tile if any input changed.
void CpuLevelRuntime::skip_block_lightmap(std::size_t i, std::span<float> lightmap, int thread) {
  const Level& level = *level_;
  const std::size_t kb = level.kb, kr = level.kr;
  const bool force = !skip_state_valid_;
  bool inputs_changed = force || !skip_.keep_tiles || lightmap.data() != last_lightmap_ || b_changed_[i];
  double r_bound = 0.0;  // sum over the slots of ||r_s - r_s^full||_F bounds
  for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j) {
    const std::size_t s = block_slots_[j];
    bool sources_changed = force;
    double beta_sum = 0.0, total = 0.0;
    for (std::uint32_t q = slot_record_begin_[s]; q < slot_record_begin_[s + 1]; ++q) {
      const std::size_t rec = slot_records_[q], src = level.records[rec].source_block;
      sources_changed |= b_changed_[src] != 0;
      beta_sum +=
          record_d_norm_[rec] * shape_d_td_norm_[operator_set(*dict_, level.blocks[src])] * ld_delta_[src];
      total += record_weight(rec, src);
    }
    slot_kept_[s] = !sources_changed;
    r_changed_[s] = 0;
    if (sources_changed) {
      const double budget = double(skip_.record_epsilon) * total;
      double left_out = 0.0;
      std::uint32_t computed = 0, skipped = 0;
      float* r_new = r_scratch_.data() + 3 * kr * std::size_t(thread);
      std::fill(r_new, r_new + 3 * kr, 0.0f);
      for (std::uint32_t q = slot_record_begin_[s]; q < slot_record_begin_[s + 1]; ++q) {
        const std::size_t rec = slot_records_[q], src = level.records[rec].source_block;
        const double w = record_weight(rec, src);
        if (w == 0.0 || left_out + w <= budget) {
          left_out += w;
          ++skipped;
          continue;
        }
        gemv(record_ops_[rec], kr, block_kb_[src], b_planar_.data() + 3 * kb * src, r_new, true);
        ++computed;
      }
      slot_rho_[s] = left_out;
      slot_records_computed_[s] = computed;
      slot_records_skipped_[s] = skipped;
      float* r = r_.data() + 3 * kr * s;
      slot_close_[s] = 0;
      slot_drift_[s] = 0.0;
      bool replace = force || !same_bits(r_new, r, 3 * kr);
      if (replace && !force && skip_.r_epsilon > 0.0f) {  // (e) keep r_s when r_new is close to it
        double diff2 = 0.0, ref2 = 0.0;
        for (std::size_t k = 0; k < 3 * kr; ++k) {
          const double e = double(r_new[k]) - r[k];
          diff2 += e * e;
          ref2 += double(r[k]) * r[k];
        }
        const double diff = std::sqrt(diff2) * (1.0 + 1e-9);
        if (diff <= double(skip_.r_epsilon) * std::sqrt(ref2)) {
          replace = false;
          slot_close_[s] = 1;
          slot_drift_[s] = diff;
        }
      }
      if (replace) {
        std::copy(r_new, r_new + 3 * kr, r);
        deinterleave_rgb(r, kr, r_planar_.data() + 3 * kr * s, kr);
        r_changed_[s] = 1;
        inputs_changed = true;
      }
    } else {
      slot_records_computed_[s] = 0;
      slot_records_skipped_[s] = 0;
    }
    r_bound += beta_sum + slot_rho_[s] + slot_drift_[s];
  }
  tile_bound_[i] =
      shape_ub_td_norm_[operator_set(*dict_, level.blocks[i])] * ld_delta_[i] + ur_norm_ * r_bound;
  tile_written_[i] = inputs_changed;
  if (!inputs_changed) return;  // (d) the tile holds exactly what this frame would write
  // Ub b_i is kept in self_lightmap_: when only r changed, the tile restarts from a copy of
  // it (the same bits the GEMV would write) instead of the GEMV.
  const std::size_t offset = 3 * std::size_t(level.blocks[i].sample_offset);
  float* tile = lightmap.data() + offset;
  float* self = self_lightmap_.data() + offset;
  const std::size_t count = 3 * std::size_t(level.blocks[i].sample_count);
  if (force || b_changed_[i]) {
    const std::size_t shape = operator_set(*dict_, level.blocks[i]);
    gemv(shape_ops_[shape].ub, operator_set_at(*dict_, *level_, shape).Ub.rows, block_kb_[i],
         b_planar_.data() + 3 * kb * i, self, false);
  }
  std::copy(self, self + count, tile);
  // Each slot's Ur r contribution is kept too (the values the scatter adds): recomputed only
  // when its r changed, then added in slot order, which gives the scatter's bits.
  const Matrix& Ur = dict_->interfaces.Ur;
  for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j) {
    const std::size_t s = block_slots_[j];
    const std::int32_t* map = level.slots[s].ur_row_to_sample.data();
    float* contribution = slot_contribution_.data() + 3 * std::size_t(Ur.rows) * s;
    if (force || r_changed_[s])
      gemv_masked(ur_op_, Ur.rows, kr, map, r_planar_.data() + 3 * kr * s, contribution);
    add_scattered(Ur.rows, map, contribution, tile);
  }
  clamp_nonnegative(isa_, tile, count);  // the lightmap policy (core reference_runtime.h)
}

void CpuLevelRuntime::finish_skip_stats() {
  CpuSkipStats st;
  double bound2 = 0.0;
  for (std::size_t i = 0; i < block_action_.size(); ++i) {
    st.blocks_computed += block_action_[i] == kComputed;
    st.blocks_kept += block_action_[i] == kKept;
    st.blocks_dark += block_action_[i] == kDark;
    st.tiles_written += tile_written_[i] != 0;
    st.tiles_skipped += tile_written_[i] == 0;
    bound2 += tile_bound_[i] * tile_bound_[i];
  }
  for (std::size_t s = 0; s < slot_kept_.size(); ++s) {
    st.records_computed += slot_records_computed_[s];
    st.records_skipped += slot_records_skipped_[s];
    st.slots_kept += slot_kept_[s] != 0;
    st.slots_close += slot_close_[s] != 0;
  }
  st.lightmap_error_bound = std::sqrt(bound2);
  stats_ = st;
}

// Step 2 for block i: b_i = Td_b ld_i through thread's planar ld scratch; b_i kept planar too.
void CpuLevelRuntime::compute_block_b(std::size_t i, std::span<const float> ld, int thread) {
  const LevelBlock& blk = level_->blocks[i];
  const std::size_t n = blk.sample_count, kb = level_->kb, kb_i = block_kb_[i];
  float* scratch = ld_planar_.data() + 3 * max_block_samples_ * std::size_t(thread);
  deinterleave_rgb(ld.data() + 3 * std::size_t(blk.sample_offset), n, scratch, n);
  gemv(shape_ops_[operator_set(*dict_, blk)].td_b, kb_i, n, scratch, b_.data() + 3 * kb * i, false);
  deinterleave_rgb(b_.data() + 3 * kb * i, kb_i, b_planar_.data() + 3 * kb * i, kb_i);
}

void CpuLevelRuntime::build_padding_rows() {
  const Level& level = *level_;
  const LightmapAtlas& atlas = level.atlas;
  std::vector<std::int32_t> texel_sample(std::size_t(atlas.width) * std::size_t(atlas.height), -1);
  for (std::size_t s = 0; s < atlas.sample_texel.size() && s < level.sample_count; ++s)
    if (atlas.sample_texel[s] < texel_sample.size()) texel_sample[atlas.sample_texel[s]] = std::int32_t(s);
  std::vector<std::uint8_t> source(level.sample_count, 0);
  for (const PaddingRecord& p : atlas.padding)
    if (p.src < texel_sample.size() && texel_sample[p.src] >= 0) source[std::size_t(texel_sample[p.src])] = 1;
  padding_ub_rows_.assign(level.sample_count, -1);
  for (const LevelBlock& b : level.blocks)
    for (std::uint32_t local = 0; local < b.sample_count; ++local)
      if (source[b.sample_offset + local]) padding_ub_rows_[b.sample_offset + local] = std::int32_t(local);
  const std::size_t ur_rows = dict_->interfaces.Ur.rows;
  padding_ur_rows_.assign(ur_rows * level.slots.size(), -1);
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    const ResponseSlot& slot = level.slots[s];
    const std::uint32_t offset = level.blocks[slot.block].sample_offset;
    for (std::size_t t = 0; t < slot.ur_row_to_sample.size() && t < ur_rows; ++t) {
      const std::int32_t local = slot.ur_row_to_sample[t];
      if (local >= 0 && source[offset + std::uint32_t(local)]) padding_ur_rows_[ur_rows * s + t] = local;
    }
  }
}

// Steps 4, 3 and 5 for the tile of block i: r of every slot entering i (records in level
// order; only the flagged slots when `slots` is given), then lightmap_i = Ub b_i, += Ur r_s
// scattered onto each slot's entry face.
void CpuLevelRuntime::compute_block_lightmap(std::size_t i, std::span<float> lightmap,
                                             const std::uint8_t* slots, std::uint8_t write_tile) {
  const Level& level = *level_;
  const std::size_t kb = level.kb, kr = level.kr;
  float* tile = lightmap.data() + 3 * std::size_t(level.blocks[i].sample_offset);
  for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j) {
    const std::size_t s = block_slots_[j];
    if (slots && !slots[s]) continue;
    float* r = r_.data() + 3 * kr * s;
    std::fill(r, r + 3 * kr, 0.0f);
    for (std::uint32_t q = slot_record_begin_[s]; q < slot_record_begin_[s + 1]; ++q) {
      const std::size_t rec = slot_records_[q];
      const std::size_t src = level.records[rec].source_block;
      gemv(record_ops_[rec], kr, block_kb_[src], b_planar_.data() + 3 * kb * src, r, true);
    }
    deinterleave_rgb(r, kr, r_planar_.data() + 3 * kr * s, kr);
  }
  if (!write_tile) return;
  const std::size_t shape = operator_set(*dict_, level.blocks[i]);
  const std::size_t ub_rows = operator_set_at(*dict_, *level_, shape).Ub.rows,
                    ur_rows = dict_->interfaces.Ur.rows;
  // Padding sources only: the same rows of the same kernels (a row's value does not depend on
  // which rows beside it are masked), so the samples written equal the whole tile's bit for bit.
  const bool sources_only = write_tile == kPaddingSourcesOnly;
  if (sources_only)
    gemv_masked(shape_ops_[shape].ub, ub_rows, block_kb_[i],
                padding_ub_rows_.data() + level.blocks[i].sample_offset, b_planar_.data() + 3 * kb * i, tile);
  else
    gemv(shape_ops_[shape].ub, ub_rows, block_kb_[i], b_planar_.data() + 3 * kb * i, tile, false);
  for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j) {
    const std::size_t s = block_slots_[j];
    const std::int32_t* rows =
        sources_only ? padding_ur_rows_.data() + ur_rows * s : level.slots[s].ur_row_to_sample.data();
    gemv_scatter(ur_op_, ur_rows, kr, rows, r_planar_.data() + 3 * kr * s, tile);
  }
  // The lightmap policy (core reference_runtime.h): no negative texel.
  clamp_nonnegative(isa_, tile, 3 * std::size_t(level.blocks[i].sample_count));
}

Status CpuLevelRuntime::set_albedo(std::span<const float> albedo, float max_albedo) {
  if (Status s = validate_light_signal(albedo, level_->sample_count, "albedo"); !s.ok()) return s;
  if (Status s = check_max_albedo(max_albedo, "multi-bounce"); !s.ok()) return s;
  rho_max_ = clamp_albedo(albedo, max_albedo, rho_).rho_max;
  has_albedo_ = true;
  return Status::success();
}

Status CpuLevelRuntime::multi_bounce_step(std::span<const float> ld_direct, std::span<float> lightmap,
                                          bool* value_clamped) {
  if (!has_albedo_)
    return Status::error(ErrorCode::invalid_argument, "multi_bounce_step: call set_albedo first");
  if (Status s = validate_light_signal(ld_direct, level_->sample_count, "ld_direct"); !s.ok()) return s;
  if (lightmap.size() != sizes_.lightmap) return wrong_size("lightmap", lightmap.size(), sizes_.lightmap);
  const float bound = feedback_energy_bound(largest_light(ld_direct), rho_max_);
  const ScopedFlushDenormals flush(flush_denormals_);
  const bool clamped = feedback_rgb(isa_, ld_direct.data(), rho_.data(), lightmap.data(), bound,
                                    ld_feedback_.data(), ld_direct.size());
  if (value_clamped) *value_clamped = clamped;
  return evaluate(ld_feedback_, lightmap);
}

Status CpuLevelRuntime::fill_atlas(std::span<const float> lightmap, std::span<float> atlas) const {
  if (lightmap.size() != sizes_.lightmap) return wrong_size("lightmap", lightmap.size(), sizes_.lightmap);
  if (atlas.size() != sizes_.atlas) return wrong_size("atlas", atlas.size(), sizes_.atlas);
  std::fill(atlas.begin(), atlas.end(), 0.0f);
  scatter_texels(level_->atlas.sample_texel, lightmap.data(), atlas.data());
  copy_padding(level_->atlas.padding, atlas.data());
  return Status::success();
}

void CpuLevelRuntime::compute_block_probes(std::size_t i, std::span<float> probes) const {
  const Level& level = *level_;
  const std::size_t kb = level.kb, kr = level.kr;
  const std::size_t per_block = 3 * std::size_t(dict_->shapes[0].Ubvol.rows);
  float* out = probes.data() + per_block * i;
  const std::size_t shape = operator_set(*dict_, level.blocks[i]);
  gemv(shape_ops_[shape].ubvol, operator_set_at(*dict_, *level_, shape).Ubvol.rows, block_kb_[i],
       b_planar_.data() + 3 * kb * i, out, false);
  for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j) {
    const std::size_t s = block_slots_[j], face = std::size_t(level.slots[s].entry_face);
    gemv(probe_ops_[face], level.probe_response[face].rows, kr, r_planar_.data() + 3 * kr * s, out, true);
  }
}

Status CpuLevelRuntime::compute_probes(std::span<float> probes) const {
  if (probes.size() != sizes_.probes) return wrong_size("probes", probes.size(), sizes_.probes);
  if (probes.empty()) return Status::success();
  auto probe_phase = [&](std::size_t i, int) { compute_block_probes(i, probes); };
  parallel_for(level_->blocks.size(), probe_phase);
  return Status::success();
}

std::span<const std::uint32_t> CpuLevelRuntime::flagged(std::span<const std::uint8_t> flags) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < flags.size(); ++i)
    if (flags[i]) work_items_[n++] = std::uint32_t(i);
  return {work_items_.data(), n};
}

void CpuLevelRuntime::compute_b(std::span<const float> ld, std::span<const std::uint8_t> blocks) {
  const std::span<const std::uint32_t> items = flagged(blocks);
  auto b_phase = [&](std::size_t k, int thread) { compute_block_b(items[k], ld, thread); };
  parallel_for(items.size(), b_phase);
}

void CpuLevelRuntime::compute_r_and_tiles(std::span<const std::uint8_t> slots,
                                          std::span<const std::uint8_t> tiles, std::span<float> lightmap) {
  // The items: blocks with a flagged tile, and (high bit set) blocks whose tile is not flagged
  // but a flagged slot enters them.
  constexpr std::uint32_t kSlotsOnly = 0x80000000u, kSources = 0x40000000u;
  std::size_t n = 0;
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    if (tiles[i]) {
      work_items_[n++] = std::uint32_t(i) | (tiles[i] == kPaddingSourcesOnly ? kSources : 0u);
      continue;
    }
    for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j)
      if (slots[block_slots_[j]]) {
        work_items_[n++] = std::uint32_t(i) | kSlotsOnly;
        break;
      }
  }
  auto lightmap_phase = [&](std::size_t k, int) {
    const std::uint32_t item = work_items_[k];
    const std::uint8_t tile = (item & kSlotsOnly) ? 0 : (item & kSources) ? kPaddingSourcesOnly : 1;
    compute_block_lightmap(item & ~(kSlotsOnly | kSources), lightmap, slots.data(), tile);
  };
  parallel_for(n, lightmap_phase);
}

void CpuLevelRuntime::fill_atlas_blocks(std::span<const float> lightmap, std::span<float> atlas,
                                        std::span<const std::uint8_t> tiles,
                                        std::span<const std::uint8_t> rects,
                                        const AtlasBlockPadding& padding) const {
  const Level& level = *level_;
  for (std::size_t i = 0; i < level.blocks.size(); ++i)
    if (tiles[i]) {
      const LevelBlock& b = level.blocks[i];
      scatter_texels(
          std::span<const std::uint32_t>(level.atlas.sample_texel).subspan(b.sample_offset, b.sample_count),
          lightmap.data() + 3 * std::size_t(b.sample_offset), atlas.data());
    }
  for (std::size_t i = 0; i < level.blocks.size(); ++i)
    if (rects[i])
      for (std::uint32_t m : padding.records_of(i)) copy_padding({&level.atlas.padding[m], 1}, atlas.data());
}

void CpuLevelRuntime::apply_reduced_feedback(const ReducedFeedback& op, std::span<const float> x,
                                             std::span<float> out) {
  const Level& level = *level_;
  const std::size_t kb = level.kb, kr = level.kr;
  auto planar_phase = [&](std::size_t i, int) {
    deinterleave_rgb(x.data() + 3 * kb * i, block_kb_[i], x_planar_.data() + 3 * kb * i, block_kb_[i]);
  };
  parallel_for(level.blocks.size(), planar_phase);
  auto r_phase = [&](std::size_t s, int) {
    float* r = r_.data() + 3 * kr * s;
    std::fill(r, r + 3 * kr, 0.0f);
    for (std::uint32_t q = slot_record_begin_[s]; q < slot_record_begin_[s + 1]; ++q) {
      const std::size_t rec = slot_records_[q];
      const std::size_t src = level.records[rec].source_block;
      gemv(record_ops_[rec], kr, block_kb_[src], x_planar_.data() + 3 * kb * src, r, true);
    }
  };
  parallel_for(level.slots.size(), r_phase);
  auto b_phase = [&](std::size_t i, int) {
    float* dst = out.data() + 3 * kb * i;
    const std::size_t kb_i = block_kb_[i];
    if (op.A.empty() || kb_i < kb) std::fill(dst, dst + 3 * kb, 0.0f);  // zero past kb_i too
    if (!op.A.empty())
      gemv_channels(isa_, op.A[i].data.data(), kb_i, kb_i, x.data() + 3 * kb * i, dst, false);
    for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j) {
      const std::size_t s = block_slots_[j];
      gemv_channels(isa_, op.B[s].data.data(), kb_i, kr, r_.data() + 3 * kr * s, dst, true);
    }
  };
  parallel_for(level.blocks.size(), b_phase);
}

void CpuLevelRuntime::apply_reduced_feedback_delta(const ReducedFeedback& op, std::span<const float> d,
                                                   std::span<const std::uint8_t> blocks, std::span<float> y,
                                                   std::span<float> r) {
  const Level& level = *level_;
  const std::size_t kb = level.kb, kr = level.kr;
  const std::span<const std::uint32_t> items = flagged(blocks);
  auto planar_phase = [&](std::size_t k, int) {
    const std::size_t i = items[k];
    deinterleave_rgb(d.data() + 3 * kb * i, block_kb_[i], x_planar_.data() + 3 * kb * i, block_kb_[i]);
  };
  parallel_for(items.size(), planar_phase);
  auto r_phase = [&](std::size_t s, int) {
    float* rd = r_delta_.data() + 3 * kr * s;
    bool touched = false;
    for (std::uint32_t q = slot_record_begin_[s]; q < slot_record_begin_[s + 1]; ++q) {
      const std::size_t rec = slot_records_[q], src = level.records[rec].source_block;
      if (!blocks[src]) continue;
      if (!touched) std::fill(rd, rd + 3 * kr, 0.0f);
      touched = true;
      gemv(record_ops_[rec], kr, block_kb_[src], x_planar_.data() + 3 * kb * src, rd, true);
    }
    slot_touched_[s] = touched ? 1 : 0;
    if (touched) {
      float* acc = r.data() + 3 * kr * s;
      for (std::size_t k = 0; k < 3 * kr; ++k) acc[k] += rd[k];
    }
  };
  parallel_for(level.slots.size(), r_phase);
  auto b_phase = [&](std::size_t i, int) {
    float* dst = y.data() + 3 * kb * i;
    if (!op.A.empty() && blocks[i])
      gemv_channels(isa_, op.A[i].data.data(), block_kb_[i], block_kb_[i], d.data() + 3 * kb * i, dst, true);
    for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j) {
      const std::size_t s = block_slots_[j];
      if (slot_touched_[s])
        gemv_channels(isa_, op.B[s].data.data(), block_kb_[i], kr, r_delta_.data() + 3 * kr * s, dst, true);
    }
  };
  parallel_for(level.blocks.size(), b_phase);
}

void CpuLevelRuntime::reduced_rhs(const ReducedFeedback& op, std::span<const float> b0, std::span<float> c) {
  if (op.P.empty()) {
    std::copy(b0.begin(), b0.end(), c.begin());
    return;
  }
  const std::size_t kb = level_->kb;
  auto rhs_phase = [&](std::size_t i, int) {
    float* ci = c.data() + 3 * kb * i;
    gemv_channels(isa_, op.P[i].data.data(), block_kb_[i], block_kb_[i], b0.data() + 3 * kb * i, ci, false);
    std::fill(ci + 3 * std::size_t(block_kb_[i]), ci + 3 * kb, 0.0f);
  };
  parallel_for(level_->blocks.size(), rhs_phase);
}

void CpuLevelRuntime::finish_reduced_solve(std::span<const float> b_new, std::span<const float> r) {
  std::copy(b_new.begin(), b_new.end(), b_.begin());
  std::copy(r.begin(), r.end(), r_.begin());
  const std::size_t kb = level_->kb, kr = level_->kr;
  for (std::size_t i = 0; i < level_->blocks.size(); ++i)
    deinterleave_rgb(b_.data() + 3 * kb * i, block_kb_[i], b_planar_.data() + 3 * kb * i, block_kb_[i]);
  for (std::size_t s = 0; s < level_->slots.size(); ++s)
    deinterleave_rgb(r_.data() + 3 * kr * s, kr, r_planar_.data() + 3 * kr * s, kr);
}

void CpuLevelRuntime::compute_probes(std::span<const std::uint8_t> blocks, std::span<float> probes) {
  if (probes.empty()) return;
  const std::span<const std::uint32_t> items = flagged(blocks);
  auto probe_phase = [&](std::size_t k, int) { compute_block_probes(items[k], probes); };
  parallel_for(items.size(), probe_phase);
}

Status CpuLevelRuntime::compute_vector_irradiance(std::span<float> vector_lightmap) const {
  if (!vector_ready_)
    return Status::error(
        ErrorCode::invalid_argument,
        "cpu runtime: no vector irradiance: " + check_level_vector_operators(*level_, *dict_).message());
  if (vector_lightmap.size() != sizes_.vector_lightmap)
    return wrong_size("vector lightmap", vector_lightmap.size(), sizes_.vector_lightmap);
  const Level& level = *level_;
  const std::size_t kb = level.kb, kr = level.kr;
  auto vector_phase = [&](std::size_t i, int) {
    const LevelBlock& blk = level.blocks[i];
    float* out = vector_lightmap.data() + 12 * std::size_t(blk.sample_offset);
    const std::size_t shape = operator_set(*dict_, blk);
    gemv(shape_ops_[shape].ub_vec, operator_set_at(*dict_, *level_, shape).Ub_vec.rows, block_kb_[i],
         b_planar_.data() + 3 * kb * i, out, false);
    for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j) {
      const std::size_t s = block_slots_[j], face = std::size_t(level.slots[s].entry_face);
      gemv_scatter(vector_ops_[face], level.vector_response[face].rows, kr,
                   vector_row_map_.data() + vector_rows_ * s, r_planar_.data() + 3 * kr * s, out);
    }
  };
  parallel_for(level.blocks.size(), vector_phase);
  return Status::success();
}

}  // namespace modrt::cpu
