#include "distlab/kelvin/stages.hpp"

#include <algorithm>
#include <cmath>

namespace distlab::kelvin {

int prepare_stage_index(const std::string& stage, double fraction) {
  if (stage == "invert") return 1;                    // mesh_stage's first step, timed in Stats::t_mesh
  if (stage == "cache" && fraction < 0.5) return -1;  // the look-up, not the write
  for (std::size_t i = 0; i < kPrepareStageCount; ++i)
    if (stage == kPrepareStages[i]) return static_cast<int>(i);
  return -1;
}

StageSeconds typical_stage_seconds(double grading, double vertices, int mesh_threads) {
  // Each stage's seconds at 10^4 vertices, scaled to `vertices` by kStageSizeExponents: medians
  // of 12 preparations in the service at load < 1 (the cube at l_x 0.02-0.05, the wrench at
  // 0.002-0.005, the sphere, the knife; 5.7k-198k vertices), the mesh stage per thread and per
  // eq. 23 vertex (0.40-0.56 s on the cube and the sphere, 1.1-1.8 s on the featured wrench and
  // knife); the graded sizing's cost 1.85-1.9× per vertex.
  StageSeconds at_10k = {0.02, 0.6, 0.025, 0.13, 0.15, 0.3};
  if (grading > 0) at_10k[1] *= 2;
  at_10k[1] /= mesh_speedup(mesh_threads);
  StageSeconds out{};
  for (std::size_t i = 0; i < kPrepareStageCount; ++i) out[i] = at_10k[i] * std::pow(std::max(vertices, 1.0) / 1e4, kStageSizeExponents[i]);
  return out;
}

StageProgress::StageProgress(const StageSeconds& shares) {
  double total = 0;
  for (double s : shares) total += std::isfinite(s) && s > 0 ? s : 0;
  for (std::size_t i = 0; i < kPrepareStageCount; ++i) {
    const double s = std::isfinite(shares[i]) && shares[i] > 0 ? shares[i] : 0;
    shares_[i] = total > 0 ? s / total : 1.0 / kPrepareStageCount;
  }
}

double StageProgress::report(const std::string& stage, double fraction) {
  if (!std::isfinite(fraction)) fraction = 0;
  const int i = prepare_stage_index(stage, fraction);
  const std::lock_guard lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  if (i != timed_) {
    if (timed_ >= 0) seconds_[static_cast<std::size_t>(timed_)] += std::chrono::duration<double>(now - since_).count();
    timed_ = i;
    since_ = now;
  }
  if (i < 0) return overall_;
  // The write's fraction runs over the store's 0.5 … 1; "invert" only begins the meshing.
  const double f = stage == "invert" ? 0.0 : std::clamp(stage == "cache" ? 2 * fraction - 1 : fraction, 0.0, 1.0);
  auto& d = done_[static_cast<std::size_t>(i)];
  d = std::max(d, f);
  if (f > 0)
    for (int j = 0; j < i; ++j) done_[static_cast<std::size_t>(j)] = 1;
  double sum = 0;
  for (std::size_t j = 0; j < kPrepareStageCount; ++j) sum += shares_[j] * done_[j];
  overall_ = std::max(overall_, std::min(1.0, sum));
  return overall_;
}

double StageProgress::overall() const {
  const std::lock_guard lock(mutex_);
  return overall_;
}

StageSeconds StageProgress::seconds() const {
  const std::lock_guard lock(mutex_);
  return seconds_;
}

void StageProgress::finish() {
  const std::lock_guard lock(mutex_);
  if (timed_ >= 0) seconds_[static_cast<std::size_t>(timed_)] += std::chrono::duration<double>(std::chrono::steady_clock::now() - since_).count();
  timed_ = -1;
}

}  // namespace distlab::kelvin
