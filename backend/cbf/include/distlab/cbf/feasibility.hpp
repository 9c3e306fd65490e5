#pragma once
// Is a scenario's exact target pose inside the CBF safe set? The Panda reaches a 6-D pose with
// 7 joints, a one-dimensional self-motion parametrised here by q7: for each q7 on a grid over its
// range, joints 1–6 are solved for the exact target pose (damped Gauss–Newton from several seeds,
// within the joint limits: every IK branch the seeds find), and the configuration with the largest
// minimum robot–obstacle clearance is kept, then refined in q7. A rollout that stops short of the
// target can be read against this number: if the best clearance is below δ_obs, no CBF-QP with
// that margin can converge to the exact pose.
#include <cstddef>
#include <string>

#include "distlab/cbf/controller.hpp"

namespace distlab::cbf {

struct FeasibilityOptions {
  double q7_step = 1.0 * 3.14159265358979323846 / 180;  // grid step in q7 (rad)
  int seeds = 8;                                        // IK starts per grid point (q0, the previous solution, fixed spread)
  double pose_tol = 1e-10;                              // ‖pose error‖ (m and rad) for a configuration to count as reaching
};

struct Feasibility {
  bool reachable = false;     // some configuration within the joint limits reaches the pose
  VecQ q;                     // the best one
  double clearance = 0;       // its minimum robot–obstacle Euclidean clearance
  std::string limiting_pair;  // the pair that sets it
  double self_clearance = 0;  // its minimum self-collision clearance (self pairs of the scenario)
  double gap_distance = 0;    // minimum GAP D (gap.mode exact) over robot–obstacle pairs there
  std::string gap_limiting_pair;
  int configurations = 0;  // IK solutions examined
  // The margins to compare with (the scenario's δ_obs per metric).
  bool euclidean_feasible = false;  // clearance ≥ δ_obs (Euclidean)
  bool gap_feasible = false;        // gap_distance ≥ δ_obs (GAP)
  // Kelvin fields: why the start q0 is outside a field's safe set (a control point inside an
  // object or with h < δ: the run would be refused, rollout.hpp require_safe_start); empty if not.
  std::string start_problem;
};

Feasibility target_feasibility(const Scenario& scenario, const FeasibilityOptions& options = {});

// About as many configurations as one target_feasibility examines with the default options
// (a q7 grid of 1°, seeds and continuations), each against every pair: the work is pairs × this.
inline constexpr std::size_t kFeasibilityConfigurations = 4000;

}  // namespace distlab::cbf
