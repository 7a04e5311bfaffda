#include "modrt/cpu/cpu_backend.h"

#include <algorithm>
#include <string>
#include <vector>

namespace modrt::cpu {
namespace {

class CpuBackend final : public Backend {
 public:
  explicit CpuBackend(CpuLevelRuntime runtime)
      : rt_(std::move(runtime)),
        description_(std::string("cpu ") + isa_name(rt_.isa())),
        lightmap_(rt_.sizes().lightmap, 0.0f),
        atlas_(rt_.sizes().atlas, 0.0f),
        probes_(rt_.sizes().probes, 0.0f) {}

  BackendKind kind() const override { return BackendKind::cpu; }
  const char* description() const override { return description_.c_str(); }
  const LevelBufferSizes& sizes() const override { return rt_.sizes(); }

  Status update(std::span<const float> ld) override {
    if (Status s = rt_.evaluate(ld, lightmap_); !s.ok()) return s;
    return finish();
  }
  Status set_albedo(std::span<const float> albedo, float max_albedo) override {
    return rt_.set_albedo(albedo, max_albedo);
  }
  Status multi_bounce_step(std::span<const float> ld_direct) override {
    if (!updated_)
      return Status::error(ErrorCode::invalid_argument, "cpu: multi_bounce_step: call update first");
    if (Status s = rt_.multi_bounce_step(ld_direct, lightmap_); !s.ok()) return s;
    return finish();
  }
  Status read_lightmap(std::span<float> out) override { return copy("lightmap", lightmap_, out); }
  Status read_atlas(std::span<float> out) override { return copy("atlas", atlas_, out); }
  Status read_probes(std::span<float> out) override {
    if (probes_.empty())
      return Status::error(ErrorCode::invalid_argument, "cpu: the dictionary has no probes");
    return copy("probes", probes_, out);
  }
  // Computed on request from the kept b and r, so frames that never read it pay nothing.
  Status read_vector_lightmap(std::span<float> out) override {
    if (!updated_) return Status::error(ErrorCode::invalid_argument, "cpu: read before the first update");
    return rt_.compute_vector_irradiance(out);
  }

 private:
  Status finish() {
    updated_ = true;
    if (Status s = rt_.fill_atlas(lightmap_, atlas_); !s.ok()) return s;
    return probes_.empty() ? Status::success() : rt_.compute_probes(probes_);
  }
  Status copy(const char* what, const std::vector<float>& from, std::span<float> to) const {
    if (to.size() != from.size())
      return Status::error(ErrorCode::invalid_argument, std::string("cpu: ") + what + ": has " +
                                                            std::to_string(to.size()) + " floats, expected " +
                                                            std::to_string(from.size()));
    if (!updated_) return Status::error(ErrorCode::invalid_argument, "cpu: read before the first update");
    std::copy(from.begin(), from.end(), to.begin());
    return Status::success();
  }

  CpuLevelRuntime rt_;
  std::string description_;
  std::vector<float> lightmap_, atlas_, probes_;
  bool updated_ = false;
};

}  // namespace

Result<std::unique_ptr<Backend>> create_cpu_backend(const Level& level, const Dictionary& dict,
                                                    const CpuRuntimeOptions& options) {
  Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(level, dict, options);
  if (!rt.ok()) return rt.status();
  return std::unique_ptr<Backend>(new CpuBackend(std::move(rt).value()));
}

}  // namespace modrt::cpu
