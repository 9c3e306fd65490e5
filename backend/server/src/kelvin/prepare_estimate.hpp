#pragma once
// What a Kelvin preparation will cost, as POST /api/kelvin/estimate and an object's status say it
// (issue 37 item 3): the field vertices the mesher's sizing prediction gives for the request's own
// sizing choice (kelvin::predict_preparation), and the time those vertices take at this server's
// measured seconds per vertex.
#include <cstddef>
#include <deque>
#include <list>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>

#include <nlohmann/json.hpp>

#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/stages.hpp"
#include "distlab/mesh/surface.hpp"

namespace distlab::server {

// The seconds each stage (kelvin::kPrepareStages) of a preparation takes, as this server measured
// them on the preparations it computed, per sizing (eq. 23 and graded: the graded sizing's
// meshing costs about twice per vertex): timed by kelvin::StageProgress from the job's own
// progress reports (cache hits and shared preparations are not computations). A stage's seconds
// at n vertices are c n^p (p: kelvin::kStageSizeExponents), c the sum of its seconds over the sum
// of n^p of the sizing's last kWindow (for the boundary response, of those that built one), so a
// large preparation weighs by its size and the rate follows a faster (or busier) server within
// kWindow preparations. Before the sizing's first, kelvin::typical_stage_seconds. Thread-safe.
class PrepareRate {
 public:
  static constexpr std::size_t kWindow = 16;
  struct Rate {
    kelvin::StageSeconds stages{};  // seconds per vertex of each stage, at the vertices asked
    double seconds_per_vertex = 0;  // their sum
    std::size_t preparations = 0;   // measured ones in the window; 0: the typical rates
    const char* sizing = "any";     // "eq23", "graded", or "any" (both windows: the sizing unknown)
  };
  // The mesh stage is kept in one-thread seconds (its seconds × kelvin::mesh_speedup of the
  // threads it meshed on), so fields meshed on one thread and on several share one rate.
  void record(double grading, int mesh_threads, const kelvin::StageSeconds& measured, double vertices);
  // The rate of the sizing `grading` meshes (without it, of both sizings' preparations
  // together) at `vertices` (without them, the measured preparations' mean; 10^4 before any),
  // meshed on mesh_threads.
  Rate rate(std::optional<double> grading, std::optional<double> vertices, int mesh_threads = 1) const;

 private:
  struct Measured {
    kelvin::StageSeconds seconds;
    double vertices;
  };
  mutable std::mutex mutex_;
  std::deque<Measured> recent_[2];  // eq. 23, graded
};

// The last kSize predictions by key (kelvin::prepare_key: the surface and the options, and the mesh_threads asked), so that
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

// {"vertices_predicted", "grading", "grading_chosen", "mesh_threads", "seconds_estimate", "stage_seconds",
// "seconds_per_vertex": {"value", "source": "default" | "measured", "preparations", "sizing",
// "stages", "size_exponents"}}: the rate of the sizing predicted at the vertices predicted; with
// no prediction the first four, the seconds and the stage seconds are null and the rate is the
// sizing's given in `grading` (or any) at the measured preparations' mean vertices. A boundary
// response whose least predicted memory is over max_response_megabytes (Limits::
// max_response_bytes) will not be built: its stage counts 0 seconds.
nlohmann::json prediction_json(const std::optional<kelvin::PreparePrediction>& p, const PrepareRate& rates,
                               std::optional<double> grading, double max_response_megabytes);
// The same in two steps: the rate it reads (at p's vertices, or the sizing `grading`'s mean), and
// the JSON of p at that rate.
PrepareRate::Rate prediction_rate(const std::optional<kelvin::PreparePrediction>& p, const PrepareRate& rates,
                                  std::optional<double> grading, double max_response_megabytes);
nlohmann::json prediction_json(const std::optional<kelvin::PreparePrediction>& p, const PrepareRate::Rate& rate);
// The shares of a preparation's stages for its progress (kelvin::StageProgress): the predicted
// seconds of each stage (the rate of the sizing predicted, or of `grading`, at the predicted
// vertices or the measured preparations' mean), as prediction_rate gives them.
kelvin::StageSeconds stage_shares(const std::optional<kelvin::PreparePrediction>& p, const PrepareRate& rates,
                                  std::optional<double> grading, double max_response_megabytes);

}  // namespace distlab::server
