// SPDX-License-Identifier: MIT
#include "modrt/operator_limits.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace modrt {
namespace {

std::string shape_where(std::size_t shape) {
  return "shape " + std::to_string(shape) + " (" + dictionary_shape_name(int(shape)) + "): ";
}

std::string operator_set_where(const Dictionary& dict, std::size_t set) {
  return set < dict.shapes.size() ? shape_where(set)
                                  : "shaped operators " + std::to_string(set - dict.shapes.size()) + ": ";
}

double column_norm2(const Matrix& m, std::uint32_t c) {
  double s = 0.0;
  for (std::uint32_t r = 0; r < m.rows; ++r) s += double(m(r, c)) * double(m(r, c));
  return std::sqrt(s);
}

double row_norm(const Matrix& m, std::uint32_t r, int p) {
  double s = 0.0;
  for (float v : m.row(r)) s += p == 1 ? std::abs(double(v)) : double(v) * double(v);
  return p == 1 ? s : std::sqrt(s);
}

// Largest column infinity norm (= largest |entry|) and the column holding it.
void add_max_entry(std::vector<OperatorMeasure>& out, const std::string& where, const char* name,
                   const Matrix& m, double limit) {
  double best = 0.0;
  std::size_t at = 0;
  for (std::size_t i = 0; i < m.data.size(); ++i)
    if (std::abs(double(m.data[i])) > best) best = std::abs(double(m.data[i])), at = i;
  const std::string entry = m.cols == 0 ? std::string(name)
                                        : std::string(name) + "[" + std::to_string(at / m.cols) + "," +
                                              std::to_string(at % m.cols) + "]";
  out.push_back({where + entry, std::string("|") + name + "|", best, limit});
}

}  // namespace

double shaped_transfer_factor(const glm::vec3& extent) {
  const double longest = std::max({extent.x, extent.y, extent.z}),
               shortest = std::min({extent.x, extent.y, extent.z});
  return shortest > 0.0 && std::isfinite(longest) ? std::sqrt(longest / shortest) : 1.0;
}

double prior_scale(const DictionarySettings& s) {
  if (s.enrichment_iterations > 0) return std::sqrt(3.0);
  const double g = s.prior_grid;
  return std::max(1.0, std::sqrt(g * g * g));
}

namespace {

double lightfield_samples(const DictionarySettings& s) {
  return double(s.lightfield_spatial) * s.lightfield_directional;
}

// The per-shape measures of one operator set (a dictionary shape or a level's shaped
// operators): both must meet the same limits.
void measure_shape_operators(const ShapeOperators& op, const std::string& where, double scale,
                             double lightfield, double transfer_factor, std::vector<OperatorMeasure>& out) {
  OperatorMeasure mode{where, "||Ub_k||_2 ||Td_b,k||_2", 0.0, kModeTransferLimit * transfer_factor};
  OperatorMeasure ub{where, "||Ub_k||_2", 0.0, kModeTransferLimit * transfer_factor * scale};
  OperatorMeasure td{where, "||Td_b,k||_1", 0.0, kMaxOutputGain};
  OperatorMeasure limp{where, "||Limp_k||_2", 0.0, kLimpScaleLimit * scale};
  for (std::uint32_t k = 0; k < op.Ub.cols && k < op.Td_b.rows; ++k) {
    const double u = column_norm2(op.Ub, k), t2 = row_norm(op.Td_b, k, 2), t1 = row_norm(op.Td_b, k, 1);
    if (u * t2 > mode.value)
      mode.value = u * t2,
      mode.where = where + "Ub column " + std::to_string(k) + " x Td_b row " + std::to_string(k);
    if (u > ub.value) ub.value = u, ub.where = where + "Ub column " + std::to_string(k);
    if (t1 > td.value) td.value = t1, td.where = where + "Td_b row " + std::to_string(k);
  }
  for (std::uint32_t k = 0; k < op.Limp.cols; ++k) {
    const double l = column_norm2(op.Limp, k);
    if (l > limp.value) limp.value = l, limp.where = where + "Limp column " + std::to_string(k);
  }
  out.push_back(mode);
  out.push_back(ub);
  out.push_back(td);
  out.push_back(limp);
  add_max_entry(out, where, "Ub_vec", op.Ub_vec, kUbVecGatherLimit * scale);
  add_max_entry(out, where, "Ubvol", op.Ubvol, kUbvolGatherLimit * scale);
  for (int f = 0; f < kFaceCount; ++f)
    if (!op.Rb_rlf[std::size_t(f)].empty())
      add_max_entry(out, where, (std::string("Rb_rlf(") + face_name(f) + ")").c_str(),
                    op.Rb_rlf[std::size_t(f)], kRbRlfGatherLimit * lightfield * scale);
}

}  // namespace

std::vector<OperatorMeasure> measure_dictionary_operators(const Dictionary& dict) {
  std::vector<OperatorMeasure> out;
  for (std::size_t s = 0; s < dict.shapes.size(); ++s)
    measure_shape_operators(dict.shapes[s], shape_where(s), prior_scale(dict.settings),
                            lightfield_samples(dict.settings), 1.0, out);
  const InterfaceOperators& io = dict.interfaces;
  const std::pair<const char*, const Matrix*> interfaces[] = {
      {"R_straight", &io.R_straight}, {"R_left", &io.R_left}, {"R_right", &io.R_right},
      {"Trlf_r", &io.Trlf_r},         {"Ur", &io.Ur},         {"Urvol", &io.Urvol},
      {"Ur_vec", &io.Ur_vec},
  };
  for (const auto& [name, m] : interfaces)
    if (!m->empty()) add_max_entry(out, "interfaces: ", name, *m, kInterfaceEntryLimit);
  return out;
}

std::vector<OperatorMeasure> measure_level_operators(const Level& level) {
  std::vector<OperatorMeasure> out;
  OperatorMeasure t{"records", "|T|", 0.0, kInterfaceEntryLimit};
  for (std::size_t i = 0; i < level.records.size(); ++i) {
    const Matrix& T = level.records[i].T;
    for (std::size_t j = 0; j < T.data.size(); ++j)
      if (std::abs(double(T.data[j])) > t.value)
        t.value = std::abs(double(T.data[j])), t.where = "record " + std::to_string(i) + ": T[" +
                                                         std::to_string(j / std::max(T.cols, 1u)) + "," +
                                                         std::to_string(j % std::max(T.cols, 1u)) + "]";
  }
  out.push_back(t);
  for (int e = 0; e < kFaceCount; ++e) {
    const std::string where = "entry face " + std::to_string(e) + ": ";
    if (!level.probe_response[std::size_t(e)].empty())
      add_max_entry(out, where, "probe_response", level.probe_response[std::size_t(e)], kInterfaceEntryLimit);
    if (!level.vector_response[std::size_t(e)].empty())
      add_max_entry(out, where, "vector_response", level.vector_response[std::size_t(e)],
                    kInterfaceEntryLimit);
  }
  return out;
}

std::vector<OperatorMeasure> measure_level_gain(const Level& level, const Dictionary& dict) {
  const std::uint32_t kr = level.kr;
  // b_k <= ||Td_b,k||_1 max(ld): per operator set (dictionary shape or shaped) and mode.
  std::vector<std::vector<double>> tdb(operator_set_count(dict, level));
  OperatorMeasure b{"b", "gain ld -> b", 0.0, kMaxOutputGain};
  for (std::size_t s = 0; s < tdb.size(); ++s) {
    const Matrix& T = operator_set_at(dict, level, s).Td_b;
    for (std::uint32_t k = 0; k < T.rows; ++k) {
      tdb[s].push_back(row_norm(T, k, 1));
      if (tdb[s].back() > b.value)
        b.value = tdb[s].back(), b.where = operator_set_where(dict, s) + "Td_b row " + std::to_string(k);
    }
  }
  auto block_gain = [&](std::size_t block) -> const std::vector<double>& {
    return tdb[operator_set(dict, level.blocks[block])];
  };
  // r_slot <= sum over its records |T| b.
  std::vector<double> rgain(std::size_t(kr) * level.slots.size(), 0.0);
  for (const ResponseRecord& rec : level.records) {
    const std::vector<double>& g = block_gain(rec.source_block);
    for (std::uint32_t i = 0; i < kr; ++i) {
      double acc = 0.0;
      for (std::uint32_t k = 0; k < rec.T.cols; ++k) acc += std::abs(double(rec.T(i, k))) * g[k];
      rgain[std::size_t(kr) * rec.slot + i] += acc;
    }
  }
  OperatorMeasure r{"r", "gain ld -> r", 0.0, kMaxOutputGain};
  for (std::size_t i = 0; i < rgain.size(); ++i)
    if (rgain[i] > r.value) r.value = rgain[i], r.where = "slot " + std::to_string(i / std::max(kr, 1u));

  // Row gains of an operator applied to block b (own) or slot r (response).
  auto row_gain = [](const Matrix& m, std::uint32_t row, const double* g) {
    double acc = 0.0;
    for (std::uint32_t k = 0; k < m.cols; ++k) acc += std::abs(double(m(row, k))) * g[k];
    return acc;
  };
  // lightmap and vector irradiance per sample, probes per block row.
  std::vector<double> lm(level.sample_count, 0.0), vec(4 * std::size_t(level.sample_count), 0.0);
  const std::size_t probe_rows = dict.shapes.empty() ? 0 : dict.shapes[0].Ubvol.rows;
  std::vector<double> probes(probe_rows * level.blocks.size(), 0.0);
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const LevelBlock& blk = level.blocks[i];
    const ShapeOperators& op = block_operators(dict, level, blk);
    const double* g = block_gain(i).data();
    for (std::uint32_t t = 0; t < blk.sample_count; ++t) {
      lm[blk.sample_offset + t] = row_gain(op.Ub, t, g);
      if (op.Ub_vec.rows == 4 * blk.sample_count)
        for (std::uint32_t c = 0; c < 4; ++c)
          vec[4 * std::size_t(blk.sample_offset + t) + c] = row_gain(op.Ub_vec, 4 * t + c, g);
    }
    if (op.Ubvol.rows == probe_rows)
      for (std::uint32_t p = 0; p < probe_rows; ++p) probes[probe_rows * i + p] = row_gain(op.Ubvol, p, g);
  }
  const Matrix& Ur = dict.interfaces.Ur;
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    const ResponseSlot& slot = level.slots[s];
    const LevelBlock& blk = level.blocks[slot.block];
    const double* g = rgain.data() + std::size_t(kr) * s;
    const Matrix& V = level.vector_response[std::size_t(slot.entry_face)];
    for (std::size_t row = 0; row < slot.ur_row_to_sample.size() && row < Ur.rows; ++row) {
      const std::int32_t sample = slot.ur_row_to_sample[row];
      if (sample < 0) continue;
      lm[blk.sample_offset + std::uint32_t(sample)] += row_gain(Ur, std::uint32_t(row), g);
      if (V.rows == 4 * slot.ur_row_to_sample.size() && V.cols == kr)
        for (std::uint32_t c = 0; c < 4; ++c)
          vec[4 * std::size_t(blk.sample_offset + std::uint32_t(sample)) + c] +=
              row_gain(V, std::uint32_t(4 * row + c), g);
    }
    const Matrix& P = level.probe_response[std::size_t(slot.entry_face)];
    if (P.rows == probe_rows && P.cols == kr)
      for (std::uint32_t p = 0; p < probe_rows; ++p) probes[probe_rows * slot.block + p] += row_gain(P, p, g);
  }
  auto largest = [](const std::vector<double>& v, const char* what, const char* unit, std::size_t per) {
    OperatorMeasure m{what, std::string("gain ld -> ") + what, 0.0, kMaxOutputGain};
    for (std::size_t i = 0; i < v.size(); ++i)
      if (v[i] > m.value) m.value = v[i], m.where = std::string(unit) + " " + std::to_string(i / per);
    return m;
  };
  std::vector<OperatorMeasure> out = {
      b, r, largest(lm, "lightmap", "sample", 1),
      largest(probes, "probes", "block", std::max<std::size_t>(probe_rows, 1)),
      largest(vec, "vector irradiance", "sample", 4)};
  // A level's shaped operators meet the dictionary shapes' limits (measure_dictionary_operators).
  for (std::size_t s = 0; s < level.shaped.size(); ++s)
    measure_shape_operators(level.shaped[s].operators, operator_set_where(dict, dict.shapes.size() + s),
                            prior_scale(dict.settings), lightfield_samples(dict.settings),
                            shaped_transfer_factor(level.shaped[s].extent), out);
  return out;
}

Status check_measures(const std::vector<OperatorMeasure>& measures, const std::string& what,
                      const char* reason) {
  for (const OperatorMeasure& m : measures) {
    if (m.value <= m.limit) continue;
    char text[160];
    std::snprintf(text, sizeof text, " = %.6g, above the limit %.6g", m.value, m.limit);
    return Status::error(ErrorCode::invalid_argument,
                         what + ": " + m.where + ": " + m.what + text + " (operator_limits.h): " + reason);
  }
  return Status::success();
}

Status check_level_gain(const Level& level, const Dictionary& dict) {
  return check_measures(measure_level_gain(level, dict), "level with this dictionary",
                        "ld up to kMaxLightValue (1e30) could overflow float (corrupt or crafted file?)");
}

}  // namespace modrt
