#pragma once
// CBF rollouts in the service: each is a job of its session (same id), whose steps are kept here
// as they are computed so they can stream over the WebSocket ("cbf_frames" messages), be replayed
// to a late joiner and be fetched as the full record when the job ends. See /api/cbf/... in
// openapi.json for the message formats.
#include <cstddef>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/cbf/rollout.hpp"
#include "distlab/server/cbf_json.hpp"
#include "distlab/server/lifecycle.hpp"

namespace distlab::server {

struct CbfStreamOptions {
  int batch_steps = 50;         // a message carries at most this many steps ...
  double batch_seconds = 0.05;  // ... and is sent at least this often while steps come
  bool pairs = true;            // per-pair distance, clearance and witnesses in frames
  bool poses = true;            // world pose of every robot primitive in frames
};

// A Kelvin object of a rollout's scenario, as the viewer draws it.
struct CbfRolloutField {
  std::string name;
  double delta = 0;
  Pose pose;                                   // object frame in the world
  mesh::SurfaceMesh surface;                   // object frame: the file's vertices in the file's order
  std::vector<double> sigma;                   // σ at those vertices
  std::shared_ptr<const kelvin::Field> field;  // set when prepared, reset when released (under the rollout's mutex)
};

struct CbfRollout {
  // The id is the job's, known only once the job is submitted: the job's work waits for
  // id_known before it reads `id` (it may start before submit returns).
  std::string id, session;
  std::promise<void> id_set;
  std::shared_future<void> id_known = id_set.get_future().share();
  std::string scenario_name;
  nlohmann::json scenario_json;  // the scenario as given (file content or inline object)
  cbf::Scenario scenario;
  cbf::Metric metric = cbf::Metric::gap;
  bool record_pairs = true;  // the request's params.record_pairs (record endpoint)
  CbfStreamOptions stream;
  int steps_total = 0;
  std::vector<cbf::PairInfo> pairs;
  // Kelvin fields (empty without): the control points and objects. Their preparation (under
  // mutex) is long work of its own: fields_state_word says it in the API's words, preparing
  // (queued, running) | ready (succeeded) | released (succeeded, fields_released) | failed.
  std::vector<cbf::ControlPoint> control_points;
  std::vector<CbfRolloutField> fields;
  Lifecycle fields_state = Lifecycle::queued;
  bool fields_released = false;           // for newer rollouts' (Limits::cbf_fields_kept_total)
  const char* fields_state_word() const;  // under mutex

  mutable std::mutex mutex;
  std::vector<cbf::StepRecord> steps;                // computed so far (moved into `record` at the end)
  std::shared_ptr<const cbf::RolloutRecord> record;  // set when the run ended (succeeded or cancelled)
  Lifecycle state = Lifecycle::queued;

  std::size_t steps_done() const;
  const std::vector<cbf::StepRecord>& steps_locked() const { return record ? record->steps : steps; }
  // {"id", "state", "scenario", "metric", "steps_total", "steps_done", "dt", "pairs": [{"name",
  //  "a", "b", "self"}], "margins": {"obstacle", "self"} (the metric's δ), "obstacles", "target",
  //  "stream", "robot"} (+ "summary" when ended; + "kelvin": {"state", "control_points",
  //  "fields": [{"name", "delta", "pose"}]} with fields).
  nlohmann::json status_json() const;
};

// A rollout's state in the API's words: queued | running | finished (succeeded) | cancelled | failed.
const char* rollout_state_word(Lifecycle state);

// A "cbf_frames" message of steps [first, first + count) (clamped to what exists); with fields,
// each frame's "kelvin": [per field: encode_field_step].
nlohmann::json cbf_frames_json(const CbfRollout& rollout, std::size_t first, std::size_t count);
// GET /api/cbf/robot?name=: the URDF as data: links, joints (origin, axis), limits, end effector,
// every collision primitive and the self-collision pairs.
nlohmann::json cbf_robot_json(const cbf::Robot& robot);

class CbfRolloutStore {
 public:
  // Keeps cbf_rollouts_kept_per_session, cbf_rollouts_kept_total and cbf_fields_kept_total.
  explicit CbfRolloutStore(const Limits& limits) : limits_(limits) {}
  // Adds r; forgets the oldest ended rollouts past the per-session / total limits and those whose
  // session is gone (alive(session) false).
  void add(const std::shared_ptr<CbfRollout>& r, const std::function<bool(const std::string&)>& alive);
  std::shared_ptr<CbfRollout> find(const std::string& session, const std::string& id) const;  // owner only
  std::vector<std::shared_ptr<CbfRollout>> list(const std::string& session) const;
  // r's fields are prepared: it keeps them, and rollouts past cbf_fields_kept_total newer
  // ones release theirs (a running job keeps its own reference until it ends).
  void fields_ready(const std::shared_ptr<CbfRollout>& r);

 private:
  Limits limits_;
  mutable std::mutex mutex_;
  std::vector<std::shared_ptr<CbfRollout>> rollouts_;   // oldest first
  std::vector<std::weak_ptr<CbfRollout>> with_fields_;  // holding prepared fields, oldest first
};

}  // namespace distlab::server
