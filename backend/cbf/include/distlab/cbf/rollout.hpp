#pragma once
// A closed-loop rollout q ← q + u·dt (franka-corridor.md) with a full per-step record.
#include <atomic>
#include <functional>
#include <vector>

#include "distlab/cbf/controller.hpp"

namespace distlab::cbf {

struct StepRecord {
  double t = 0;
  VecQ q = VecQ::Zero();  // the state the step was computed at
  VecQ u = VecQ::Zero();
  double task_error = 0;
  double min_clearance = 0;  // smallest true Euclidean clearance over all pairs
  bool relaxed = false;      // infeasible QP, relaxed with a slack
  bool held = false;         // relaxation failed too, u = 0
  double slack = 0;
  StepTiming timing;
  std::vector<PairSample> pairs;  // empty unless RolloutOptions::record_pairs
};

struct TimingSummary {  // means over the steps, microseconds
  double kinematics = 0, distance = 0, qp = 0, step = 0, audit = 0;
};

struct RolloutRecord {
  Metric metric = Metric::gap;
  double dt = 0;
  std::vector<PairInfo> pairs;
  std::vector<StepRecord> steps;
  std::vector<int> infeasible_steps;  // indices of relaxed or held steps
  VecQ q_final = VecQ::Zero();
  double final_task_error = 0;  // ‖r‖ at q_final
  bool reached = false;         // final_task_error < scenario.goal_tolerance
  double min_clearance = 0;     // over the whole rollout
  bool cancelled = false;
  int cold_solves = 0;          // GAP: pair solves that were not warm-started
  TimingSummary timing;
  double wall_seconds = 0;      // the whole rollout, recording included
};

struct RolloutOptions {
  bool record_pairs = true;
  bool audit_clearance = true;  // needed for min_clearance with the GAP metric
  // Called after every step with its index and record; return false to stop.
  std::function<bool(int, const StepRecord&)> progress;
  const std::atomic<bool>* cancel = nullptr;
};

RolloutRecord rollout(const Scenario& scenario, Metric metric, const RolloutOptions& options = {});

// Smoothness of one joint's velocity (paper Fig. 4): Σ|Δu| and max |Δu|/dt.
struct Smoothness {
  double total_variation = 0;
  double max_rate = 0;
};
Smoothness smoothness(const RolloutRecord& record, int joint, double t_begin = 0,
                      double t_end = 1e300);

}  // namespace distlab::cbf
