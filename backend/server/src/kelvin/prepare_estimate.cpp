#include "prepare_estimate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string_view>

namespace distlab::server {

using json = nlohmann::json;

static std::size_t sizing_index(double grading) { return grading > 0 ? 1 : 0; }
static constexpr std::size_t kMeshStage = 1, kResponseStage = 5;  // kelvin::kPrepareStages
static_assert(std::string_view(kelvin::kPrepareStages[kMeshStage]) == "mesh");
static_assert(std::string_view(kelvin::kPrepareStages[kResponseStage]) == "response");

void PrepareRate::record(double grading, int mesh_threads, const kelvin::StageSeconds& measured, double vertices) {
  kelvin::StageSeconds seconds = measured;
  seconds[kMeshStage] *= kelvin::mesh_speedup(mesh_threads);
  double total = 0;
  for (double s : seconds) {
    if (!(s >= 0) || !std::isfinite(s)) return;
    total += s;
  }
  if (!(total > 0) || !(vertices > 0) || !std::isfinite(vertices) || !std::isfinite(grading)) return;
  std::lock_guard lock(mutex_);
  auto& recent = recent_[sizing_index(grading)];
  recent.push_back({seconds, vertices});
  if (recent.size() > kWindow) recent.pop_front();
}

PrepareRate::Rate PrepareRate::rate(std::optional<double> grading, std::optional<double> vertices, int mesh_threads) const {
  Rate out;
  out.sizing = !grading ? "any" : *grading > 0 ? "graded"
                                               : "eq23";
  // Σ seconds and Σ n^p of each stage over the preparations that ran it (a boundary response
  // over the limit is not built: 0 seconds there say nothing of its rate).
  kelvin::StageSeconds seconds{}, sizes{};
  double n_sum = 0;
  {
    std::lock_guard lock(mutex_);
    for (std::size_t k = 0; k < 2; ++k) {
      if (grading && k != sizing_index(*grading)) continue;
      for (const auto& m : recent_[k]) {
        for (std::size_t i = 0; i < kelvin::kPrepareStageCount; ++i) {
          if (i == kResponseStage && !(m.seconds[i] > 0)) continue;
          seconds[i] += m.seconds[i];
          sizes[i] += std::pow(m.vertices, kelvin::kStageSizeExponents[i]);
        }
        n_sum += m.vertices;
        ++out.preparations;
      }
    }
  }
  const double n = std::max(1.0, vertices.value_or(out.preparations > 0 ? n_sum / static_cast<double>(out.preparations) : 1e4));
  // Stages none of them ran (all, before the first preparation) at the typical rates.
  out.stages = kelvin::typical_stage_seconds(grading.value_or(kelvin::kAutoGrading), n, mesh_threads);
  for (std::size_t i = 0; i < kelvin::kPrepareStageCount; ++i)
    out.stages[i] = sizes[i] > 0 ? seconds[i] / sizes[i] * std::pow(n, kelvin::kStageSizeExponents[i] - 1) /
                                       (i == kMeshStage ? kelvin::mesh_speedup(mesh_threads) : 1.0)
                                 : out.stages[i] / n;
  for (double s : out.stages) out.seconds_per_vertex += s;
  return out;
}

std::optional<kelvin::PreparePrediction> PredictionCache::find(const std::string& key) {
  std::lock_guard lock(mutex_);
  const auto it = index_.find(key);
  if (it == index_.end()) return std::nullopt;
  order_.splice(order_.begin(), order_, it->second);
  return it->second->second;
}

void PredictionCache::put(const std::string& key, const kelvin::PreparePrediction& p) {
  std::lock_guard lock(mutex_);
  if (const auto it = index_.find(key); it != index_.end()) {
    it->second->second = p;
    order_.splice(order_.begin(), order_, it->second);
    return;
  }
  order_.emplace_front(key, p);
  index_[key] = order_.begin();
  if (order_.size() > kSize) {
    index_.erase(order_.back().first);
    order_.pop_back();
  }
}

PrepareRate::Rate prediction_rate(const std::optional<kelvin::PreparePrediction>& p, const PrepareRate& rates,
                                  std::optional<double> grading, double max_response_megabytes) {
  if (!p) return rates.rate(grading, std::nullopt);
  PrepareRate::Rate out = rates.rate(p->grading, static_cast<double>(std::llround(p->vertices)), p->mesh_threads);
  // A response surely over the limit is not built (PreparedRegistry::prepare): no time.
  if (p->response_megabytes_min() > max_response_megabytes) {
    out.seconds_per_vertex -= out.stages[kResponseStage];
    out.stages[kResponseStage] = 0;
  }
  return out;
}

json prediction_json(const std::optional<kelvin::PreparePrediction>& p, const PrepareRate& rates, std::optional<double> grading,
                     double max_response_megabytes) {
  return prediction_json(p, prediction_rate(p, rates, grading, max_response_megabytes));
}

json prediction_json(const std::optional<kelvin::PreparePrediction>& p, const PrepareRate::Rate& rate) {
  const auto n = p ? std::llround(p->vertices) : 0;
  json stages = json::object(), exponents = json::object();
  for (std::size_t i = 0; i < kelvin::kPrepareStageCount; ++i) {
    stages[kelvin::kPrepareStages[i]] = rate.stages[i];
    exponents[kelvin::kPrepareStages[i]] = kelvin::kStageSizeExponents[i];
  }
  json out = {{"vertices_predicted", nullptr},
              {"grading", nullptr},
              {"grading_chosen", nullptr},
              {"mesh_threads", nullptr},
              {"seconds_estimate", nullptr},
              {"stage_seconds", nullptr},
              {"seconds_per_vertex",
               {{"value", rate.seconds_per_vertex},
                {"source", rate.preparations > 0 ? "measured" : "default"},
                {"preparations", rate.preparations},
                {"sizing", rate.sizing},
                {"stages", stages},
                {"size_exponents", exponents}}}};
  if (p) {
    out["vertices_predicted"] = n;
    out["grading"] = p->grading;
    out["grading_chosen"] = p->chosen;
    out["mesh_threads"] = p->mesh_threads;
    out["seconds_estimate"] = static_cast<double>(n) * rate.seconds_per_vertex;
    for (auto& s : stages) s = s.get<double>() * static_cast<double>(n);
    out["stage_seconds"] = std::move(stages);
  }
  return out;
}

kelvin::StageSeconds stage_shares(const std::optional<kelvin::PreparePrediction>& p, const PrepareRate& rates,
                                  std::optional<double> grading, double max_response_megabytes) {
  // Without p, at the measured preparations' mean size.
  kelvin::StageSeconds shares = prediction_rate(p, rates, grading, max_response_megabytes).stages;
  if (p)
    for (double& s : shares) s *= static_cast<double>(std::llround(p->vertices));
  return shares;
}

}  // namespace distlab::server
