// SPDX-License-Identifier: MIT
#include "modrt/dictionary.h"

#include <cmath>
#include <cstdio>

#include "modrt/operator_limits.h"

namespace modrt {
namespace {

Status bad_setting(const char* field, const std::string& value, const char* rule) {
  return Status::error(ErrorCode::invalid_argument,
                       std::string("settings.") + field + " = " + value + ": " + rule);
}

Status check_range(const char* field, std::uint32_t v, std::uint32_t lo, std::uint32_t hi) {
  if (v >= lo && v <= hi) return Status::success();
  const std::string rule = "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return bad_setting(field, std::to_string(v), rule.c_str());
}

std::string float_text(float v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", double(v));
  return buf;
}

std::string dims(std::uint32_t rows, std::uint32_t cols) {
  return std::to_string(rows) + "x" + std::to_string(cols);
}

// "<what>: shape 2 (corridor): "
std::string shape_prefix(const std::string& what, std::size_t shape) {
  return what + ": shape " + std::to_string(shape) + " (" + dictionary_shape_name(int(shape)) + "): ";
}

Status check_matrix(const std::string& prefix, const char* name, const Matrix& m, std::uint64_t rows,
                    std::uint64_t cols) {
  if (m.rows != rows || m.cols != cols)
    return Status::error(ErrorCode::invalid_argument, prefix + name + " is " + dims(m.rows, m.cols) +
                                                          ", expected " + std::to_string(rows) + "x" +
                                                          std::to_string(cols));
  if (m.data.size() != std::uint64_t(m.rows) * m.cols)
    return Status::error(ErrorCode::invalid_argument, prefix + name + " (" + dims(m.rows, m.cols) +
                                                          ") holds " + std::to_string(m.data.size()) +
                                                          " values, expected " +
                                                          std::to_string(std::uint64_t(m.rows) * m.cols));
  for (std::size_t i = 0; i < m.data.size(); ++i) {
    const float v = m.data[i];
    if (std::isfinite(v)) continue;
    const std::string value = std::isnan(v) ? "NaN" : (v > 0 ? "+Inf" : "-Inf");
    return Status::error(ErrorCode::non_finite, prefix + name + "[" + std::to_string(i / m.cols) + "," +
                                                    std::to_string(i % m.cols) + "] is " + value);
  }
  return Status::success();
}

Status check_vector(const std::string& prefix, const char* name, const std::vector<float>& v,
                    std::uint64_t max_len) {
  if (v.size() > max_len)
    return Status::error(ErrorCode::invalid_argument, prefix + name + " has " + std::to_string(v.size()) +
                                                          " values, at most " + std::to_string(max_len) +
                                                          " expected");
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i]))
      return Status::error(ErrorCode::non_finite,
                           prefix + name + "[" + std::to_string(i) + "] is " +
                               (std::isnan(v[i]) ? "NaN" : (v[i] > 0 ? "+Inf" : "-Inf")));
  return Status::success();
}

}  // namespace

Status validate_settings(const DictionarySettings& s) {
  if (Status st = check_range("res", s.res, 1, kMaxSettingsRes); !st.ok()) return st;
  if (Status st = check_range("kd", s.kd, 1, kMaxSettingsModes); !st.ok()) return st;
  if (s.kb < 1 || s.kb > s.kd)
    return bad_setting("kb", std::to_string(s.kb),
                       ("must be in [1, kd] = [1, " + std::to_string(s.kd) + "]").c_str());
  if (Status st = check_range("rays", s.rays, 1, kMaxSettingsRays); !st.ok()) return st;
  if (Status st = check_range("enrichment_iterations", s.enrichment_iterations, 0, kMaxSettingsEnrichment);
      !st.ok())
    return st;
  if (Status st = check_range("prior_grid", s.prior_grid, 1, kMaxSettingsPriorGrid); !st.ok()) return st;
  if (Status st = check_range("light_samples", s.light_samples, 1, kMaxSettingsLightSamples); !st.ok())
    return st;
  if (!std::isfinite(s.light_radius) || !(s.light_radius > 0.0f) || !(s.light_radius < 0.5f))
    return bad_setting("light_radius", float_text(s.light_radius), "must be finite and in (0, 0.5)");
  if (Status st = check_range("sh_rays", s.sh_rays, 1, kMaxSettingsRays); !st.ok()) return st;
  if (Status st = check_range("probe_grid", s.probe_grid, 1, kMaxSettingsProbeGrid); !st.ok()) return st;
  // Interface settings matter only when interface operators are baked.
  if (s.lightfield_spatial > 0) {
    if (Status st = check_range("lightfield_spatial", s.lightfield_spatial, 1, kMaxSettingsLightfieldSpatial);
        !st.ok())
      return st;
    if (Status st = check_range("lightfield_directional", s.lightfield_directional, 1,
                                kMaxSettingsLightfieldDirectional);
        !st.ok())
      return st;
    if (Status st = check_range("lightfield_supersample", s.lightfield_supersample, 1,
                                kMaxSettingsLightfieldSupersample);
        !st.ok())
      return st;
    if (Status st = check_range("krlf", s.krlf, 1, kMaxSettingsModes); !st.ok()) return st;
    if (Status st = check_range("kr", s.kr, 1, kMaxSettingsModes); !st.ok()) return st;
    if (Status st = check_range("interface_enrichment_iterations", s.interface_enrichment_iterations, 0,
                                kMaxSettingsEnrichment);
        !st.ok())
      return st;
    if (Status st = check_range("response_rays", s.response_rays, 1, kMaxSettingsRays); !st.ok()) return st;
  }
  return Status::success();
}

Status validate_dictionary(const Dictionary& dict, const std::string& what) {
  if (Status s = validate_settings(dict.settings); !s.ok())
    return Status::error(s.code(), what + ": " + s.message());
  const DictionarySettings& st = dict.settings;
  if (dict.shapes.size() != std::size_t(kDictionaryShapeCount))
    return Status::error(ErrorCode::invalid_argument, what + ": " + std::to_string(dict.shapes.size()) +
                                                          " shapes, expected " +
                                                          std::to_string(kDictionaryShapeCount));
  const std::uint64_t kb = st.kb;
  const std::uint64_t g = st.probe_grid;
  const bool with_interfaces = st.lightfield_spatial > 0;
  for (std::size_t i = 0; i < dict.shapes.size(); ++i) {
    const ShapeOperators& op = dict.shapes[i];
    const std::string prefix = shape_prefix(what, i);
    const FaceMask mask = dictionary_shape_mask(int(i));
    if (op.face_mask != mask)
      return Status::error(ErrorCode::invalid_argument,
                           prefix + "face mask " + std::to_string(unsigned(op.face_mask)) +
                               " differs from the shape's mask " + std::to_string(unsigned(mask)));
    const std::uint64_t n = std::uint64_t(face_count(mask)) * st.res * st.res;
    if (Status s = check_matrix(prefix, "Ub", op.Ub, n, kb); !s.ok()) return s;
    if (Status s = check_matrix(prefix, "Td_b", op.Td_b, kb, n); !s.ok()) return s;
    if (Status s = check_matrix(prefix, "Limp", op.Limp, n, kb); !s.ok()) return s;
    if (Status s = check_matrix(prefix, "Ub_vec", op.Ub_vec, 4 * n, kb); !s.ok()) return s;
    if (Status s = check_matrix(prefix, "Ubvol", op.Ubvol, 9 * g * g * g, kb); !s.ok()) return s;
    if (Status s = check_vector(prefix, "sigma_M", op.sigma_M, n); !s.ok()) return s;
    for (int f = 0; f < kFaceCount; ++f) {
      const std::string name = std::string("Rb_rlf(") + face_name(f) + ")";
      const Matrix& R = op.Rb_rlf[std::size_t(f)];
      const bool side = f != kFaceNegY && f != kFacePosY;
      const bool wanted = with_interfaces && side && !face_present(mask, f);
      if (!wanted) {
        if (!R.empty() || R.rows != 0 || R.cols != 0)
          return Status::error(
              ErrorCode::invalid_argument,
              prefix + name + " is " + dims(R.rows, R.cols) + ", expected empty (" +
                  (with_interfaces ? "the face is present" : "settings.lightfield_spatial = 0") + ")");
        continue;
      }
      if (Status s = check_matrix(prefix, name.c_str(), R, st.krlf, kb); !s.ok()) return s;
    }
  }

  const InterfaceOperators& io = dict.interfaces;
  const std::string prefix = what + ": interfaces: ";
  const struct {
    const char* name;
    const Matrix* m;
    std::uint64_t rows, cols;
  } interface_matrices[] = {
      {"R_straight", &io.R_straight, st.krlf, st.krlf},
      {"R_left", &io.R_left, st.krlf, st.krlf},
      {"R_right", &io.R_right, st.krlf, st.krlf},
      {"Trlf_r", &io.Trlf_r, st.kr, st.krlf},
      {"Ur", &io.Ur, std::uint64_t(face_count(dictionary_shape_mask(1))) * st.res * st.res, st.kr},
      {"Urvol", &io.Urvol, 9ull * st.probe_grid * st.probe_grid * st.probe_grid, st.kr},
      {"Ur_vec", &io.Ur_vec, 4ull * face_count(dictionary_shape_mask(1)) * st.res * st.res, st.kr},
  };
  for (const auto& e : interface_matrices) {
    if (!with_interfaces) {
      if (e.m->rows != 0 || e.m->cols != 0 || !e.m->empty())
        return Status::error(ErrorCode::invalid_argument,
                             prefix + e.name + " is " + dims(e.m->rows, e.m->cols) +
                                 ", expected empty (settings.lightfield_spatial = 0)");
      continue;
    }
    if (Status s = check_matrix(prefix, e.name, *e.m, e.rows, e.cols); !s.ok()) return s;
  }
  // Finite and of the right size; now plausible (operator_limits.h).
  return check_measures(measure_dictionary_operators(dict), what);
}

}  // namespace modrt
