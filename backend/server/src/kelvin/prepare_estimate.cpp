#include "prepare_estimate.hpp"

#include <chrono>
#include <cmath>

namespace distlab::server {

using json = nlohmann::json;

void PrepareRate::record(double seconds, double vertices) {
  if (!(seconds > 0) || !(vertices > 0) || !std::isfinite(seconds) || !std::isfinite(vertices)) return;
  std::lock_guard lock(mutex_);
  recent_.emplace_back(seconds, vertices);
  if (recent_.size() > kWindow) recent_.pop_front();
}

PrepareRate::Rate PrepareRate::rate() const {
  std::lock_guard lock(mutex_);
  if (recent_.empty()) return {};
  double seconds = 0, vertices = 0;
  for (const auto& [s, n] : recent_) seconds += s, vertices += n;
  return {seconds / vertices, recent_.size()};
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

CancelAfter::CancelAfter(double seconds) {
  if (!(seconds > 0)) return;
  thread_ = std::thread([this, seconds] {
    std::unique_lock lock(mutex_);
    if (!cv_.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return done_; })) flag_.store(true);
  });
}

CancelAfter::~CancelAfter() {
  {
    std::lock_guard lock(mutex_);
    done_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

json prediction_json(const std::optional<kelvin::PreparePrediction>& p, const PrepareRate::Rate& rate) {
  json out = {{"vertices_predicted", nullptr},
              {"grading", nullptr},
              {"grading_chosen", nullptr},
              {"seconds_estimate", nullptr},
              {"seconds_per_vertex",
               {{"value", rate.seconds_per_vertex}, {"source", rate.preparations > 0 ? "measured" : "default"}, {"preparations", rate.preparations}}}};
  if (p) {
    const auto n = std::llround(p->vertices);
    out["vertices_predicted"] = n;
    out["grading"] = p->grading;
    out["grading_chosen"] = p->chosen;
    out["seconds_estimate"] = static_cast<double>(n) * rate.seconds_per_vertex;
  }
  return out;
}

}  // namespace distlab::server
