#pragma once
// A closed-loop rollout q ← q + u·dt (franka-corridor.md) with a full per-step record.
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "distlab/cbf/controller.hpp"
#include "distlab/geometry/progress.hpp"

namespace distlab::cbf {

struct StepRecord {
  double t = 0;
  VecQ q;  // the state the step was computed at
  VecQ u;
  double task_error = 0;
  double min_clearance = 0;  // smallest true Euclidean clearance over all pairs
  bool relaxed = false;      // infeasible QP, relaxed with a slack
  bool held = false;         // relaxation failed too, u = 0
  double slack = 0;
  bool clipped = false;     // u clipped to the velocity limits
  std::vector<int> active;  // active QP rows (StepOutput::active)
  StepTiming timing;
  std::vector<PairSample> pairs;  // empty unless RolloutOptions::record_pairs
  // Kelvin fields: h at every control point (field-major, as FieldBarrier) and, per field, where
  // the points are relative to its object's surface.
  std::vector<FieldPointSample> field_points;
  std::vector<FieldContact> field_contacts;
};

// One constraint active at the final state: why the arm stops where it does.
struct ActiveConstraint {
  enum class Kind { pair,
                    field,
                    joint_limit };
  std::string name;                                                      // pair name ("link5_cylinder/wall1"), "POINT/FIELD", or "q5 >= q_min" / "q5 <= q_max"
  Kind kind = Kind::pair;                                                // a pair's distance row, a field's row or a joint limit
  double distance = 0;                                                   // the controller's D (pairs), h (fields) or the joint's distance to its limit
  double margin = 0;                                                     // δ of the row (pairs and fields), 0 for joint limits
  double clearance = 0;                                                  // true Euclidean clearance of the pair (NaN for the others)
  double converged_distance = std::numeric_limits<double>::quiet_NaN();  // as_published only
  double multiplier = 0;                                                 // the QP's multiplier: how hard the row pushes back against the task
};

// The state a rollout ends in, computed by one more control step at q_final (not applied).
struct FinalState {
  Vec3 ee_position = Vec3::Zero();
  double position_error = 0;             // |p − p_d|
  double min_clearance = 0;              // true Euclidean clearance over every pair at q_final
  std::string closest_pair;              // the pair with that clearance
  std::vector<ActiveConstraint> active;  // active QP rows at q_final, largest multiplier first
};

struct TimingSummary {  // means over the steps, microseconds
  double kinematics = 0, distance = 0, qp = 0, step = 0, audit = 0, field = 0;
};

struct RolloutRecord {
  Metric metric = Metric::gap;
  double dt = 0;
  std::vector<PairInfo> pairs;
  std::vector<StepRecord> steps;
  std::vector<int> infeasible_steps;  // indices of relaxed or held steps
  VecQ q_final;
  double final_task_error = 0;  // ‖r‖ at q_final
  bool reached = false;         // final_task_error < scenario.goal_tolerance
  double min_clearance = 0;     // over the whole rollout
  int cold_solves = 0;          // GAP: pair solves that were not warm-started
  GapMode gap_mode = GapMode::exact;
  int clipped_steps = 0;  // steps whose u was clipped to the velocity limits
  FinalState final_state;
  TimingSummary timing;
  double wall_seconds = 0;  // the whole rollout, recording included
  // Kelvin fields: the control points, and why the rollout stopped early if a field row could
  // not be formed (FieldUndefined at a step: the message and the step); empty otherwise.
  std::vector<ControlPoint> control_points;
  std::vector<std::string> field_names;
  std::vector<double> field_margins;     // δ per field
  std::vector<double> safety_distances;  // per field: FieldSurface::forbidden_offset(δ, object diagonal / 200)
  std::string failure;
  int failure_step = -1;
};

struct RolloutOptions {
  bool record_pairs = true;
  bool audit_clearance = true;  // needed for min_clearance with the GAP metric
  // Called after every step with its index and record (it may throw Cancelled to stop the run).
  std::function<void(int, const StepRecord&)> on_step;
  // Stage "rollout", the fraction of steps done, after every step; its cancel is polled before
  // and after every step and before each body of the controller's model (Cancelled).
  Progress progress;
};

// Throws InvalidInput("control_points") before the first step when a control point starts where
// h is undefined or below its field's δ (outside the safe set: no CBF can hold it there).
// Cancelled stops it between steps: the second form's `record` then holds the steps done so far,
// summarised (timing, q_final, final state; reached false), before the Cancelled is rethrown.
// It also stops the build of the controller's distance model (each body, CbfController), before
// any step: `record` is then empty.
RolloutRecord rollout(const Scenario& scenario, Metric metric, const RolloutOptions& options = {});
void rollout(const Scenario& scenario, Metric metric, const RolloutOptions& options, RolloutRecord& record);

// The start check of rollout: every control point at q has h ≥ δ in every field.
void require_safe_start(const Scenario& scenario, const VecQ& q);

// The state at q: end-effector error, closest pair, and the QP rows active there (one control
// step at q; its u is not applied).
FinalState final_state(CbfController& controller, const VecQ& q);

// Smoothness of one joint's velocity (paper Fig. 4): Σ|Δu| and max |Δu|/dt.
struct Smoothness {
  double total_variation = 0;
  double max_rate = 0;
};
Smoothness smoothness(const RolloutRecord& record, int joint, double t_begin = 0,
                      double t_end = 1e300);

}  // namespace distlab::cbf
