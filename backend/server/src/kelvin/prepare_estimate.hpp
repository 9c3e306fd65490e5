#pragma once
// What a Kelvin preparation will cost, as POST /api/kelvin/estimate and an object's status say it
// (issue 37 item 3): the field vertices the mesher's sizing prediction gives for the request's own
// sizing choice (kelvin::predict_preparation), and the time those vertices take at this server's
// measured seconds per vertex.
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <list>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <utility>

#include <nlohmann/json.hpp>

#include "distlab/kelvin/field.hpp"
#include "distlab/mesh/surface.hpp"

namespace distlab::server {

// Seconds per field vertex of the preparations this server computed (PreparedField::seconds over
// Stats::n_verts; cache hits and shared preparations are not computations): the sum of the
// seconds over the sum of the vertices of the last kWindow, so a large preparation weighs by its
// size and the rate follows a faster (or busier) server within kWindow preparations. Before the
// first, kDefault. Thread-safe.
class PrepareRate {
 public:
  // Measured on the 2-core development machine (issue 37): 0.1–0.5 ms per vertex for the
  // assets and wrapped uploads at 0.5k–45k vertices (load average about 2), up to 0.8 ms with
  // other builds running; the graded sizing about twice eq. 23's. Only a start: the first computed
  // preparation replaces it.
  static constexpr double kDefault = 3e-4;
  static constexpr std::size_t kWindow = 16;
  struct Rate {
    double seconds_per_vertex = kDefault;
    std::size_t preparations = 0;  // measured ones in the window; 0: the default
  };
  void record(double seconds, double vertices);
  Rate rate() const;

 private:
  mutable std::mutex mutex_;
  std::deque<std::pair<double, double>> recent_;  // seconds, vertices
};

// The last kSize predictions by content key (kelvin::prepare_key: the surface and the options), so that
// an estimate asked again, and the job that follows it, cost nothing more. Thread-safe.
class PredictionCache {
 public:
  static constexpr std::size_t kSize = 64;
  std::optional<kelvin::PreparePrediction> find(const std::string& key);
  void put(const std::string& key, const kelvin::PreparePrediction& p);

 private:
  std::mutex mutex_;
  std::list<std::pair<std::string, kelvin::PreparePrediction>> order_;  // most recent first
  std::unordered_map<std::string, decltype(order_)::iterator> index_;
};

// A flag that becomes true `seconds` after construction (a watchdog thread; never when seconds
// is not positive): the cancel token of work a request bounds by max_request_seconds.
class CancelAfter {
 public:
  explicit CancelAfter(double seconds);
  ~CancelAfter();
  CancelAfter(const CancelAfter&) = delete;
  CancelAfter& operator=(const CancelAfter&) = delete;
  const std::atomic<bool>* flag() const { return &flag_; }
  bool fired() const { return flag_.load(); }

 private:
  std::atomic<bool> flag_{false};
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_ = false;
  std::thread thread_;
};

// {"vertices_predicted", "grading", "grading_chosen", "seconds_estimate", "seconds_per_vertex":
// {"value", "source": "default" | "measured", "preparations"}}; with no prediction the first
// three and the seconds are null.
nlohmann::json prediction_json(const std::optional<kelvin::PreparePrediction>& p, const PrepareRate::Rate& rate);

}  // namespace distlab::server
