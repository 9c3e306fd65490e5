#pragma once
// A CBF rollout scenario: the scene, the target, the start and every controller constant
// (franka-corridor.md gives the corridor's values, which are the defaults here).
// Transport-free: the JSON codec lives in distlab_server (cbf_json).
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "distlab/cbf/fields.hpp"
#include "distlab/gap/distance.hpp"
#include "distlab/robot/distances.hpp"
#include "distlab/robot/robot.hpp"

namespace distlab::cbf {

// The robot module's vocabulary (backend/robot), which the controller is built on.
using robot::compose;
using robot::GradQ;
using robot::Jac;
using robot::Kinematics;
using robot::LinkPrimitive;
using robot::Metric;
using robot::Obstacle;
using robot::Robot;
using robot::RobotJoint;
using robot::to_string;
using robot::VecQ;

// How the GAP rows are computed (scenario field gap.mode).
// - exact: the project's P2S functions, Newton warm-started from the previous step, converged.
// - as_published: what the published package computed (franka-corridor.md, "What the authors'
//   code actually computed"): its P2S construction (box half-spaces with weight 1, cylinder
//   Φ(√(x²+y²) − r) + Φ(z − h/2) + Φ(−z − h/2) with weight 1, ρ ball with R² = 1.2 × half
//   diagonal² of the bounding box) and the plain iteration a ← Π_A(Π_B(a)) (eq. 2) cold-started
//   at B's centre every step, stopped at the first step below gap.tol or after gap.max_iter,
//   D = sqrt(max(2Λ, 0)) at that iterate. The converged D of the same functions is recorded too.
enum class GapMode { exact,
                     as_published };
const char* to_string(GapMode m);

struct Margins {
  double obstacle;  // δ_obs
  double self;      // δ_auto
};

struct Scenario {
  std::string name = "custom";
  // The arm (assets/robots/NAME.urdf); q0 and velocity_limit have one entry per joint.
  std::shared_ptr<const Robot> robot;
  std::string robot_name = "panda";
  std::vector<Obstacle> obstacles;
  Pose target;  // end-effector target pose
  VecQ q0;
  double dt = 0.01;
  double duration = 35.0;
  double task_gain = 0.4;  // K = task_gain · I₆
  double damping = 0.01;   // H = J_rᵀJ_r + damping · I
  double eta = 0.5;        // η of the obstacle and self-collision rows (eq. 7)
  double eta_joint = 0.5;  // η of the joint-limit rows
  bool self_collision = true;
  Margins gap_margins{0.002, 0.0001};
  Margins euclidean_margins{0.03, 0.01};
  // GAP metric: h = 0.1, k = 2, ε = 0.01, σ = sqrt(1 − 2ε) as in the paper. Newton from the
  // previous step's witnesses is the default solver (exact to 1e-10, 2–4 steps per pair);
  // {fixed_point, tol 2e-4, max_iter 300} reproduces the published package.
  GapParams gap;
  GapMode gap_mode = GapMode::exact;
  // |u_i| ≤ velocity_limit[i] by clipping the QP's u per joint (what the real robot's interface
  // did, franka-corridor.md); +inf or empty (the default) means no clipping.
  VecQ velocity_limit;
  // Goal test of a rollout: ‖r‖ at the last step below this counts as reached.
  double goal_tolerance = 1e-3;
  // Relaxed QP of an infeasible step: one slack s ≥ 0 on every distance row, cost ½·w·s².
  double slack_weight = 1e4;
  // Kelvin objects as barriers (fields.hpp): every control point against every field, one row
  // each, with the scenario's eta.
  std::vector<SceneField> fields;
  std::vector<ControlPoint> control_points;

  const Margins& margins(Metric m) const {
    return m == Metric::gap ? gap_margins : euclidean_margins;
  }
  int steps() const;  // round(duration / dt)
};

// The narrow corridor of franka-corridor.md (`corridor_narrow`, also
// assets/scenarios/corridor_narrow.json; the other scenarios are data only) for the Panda.
Scenario corridor_narrow_scenario(std::shared_ptr<const Robot> panda);

// Throws InvalidInput naming the field ("dt", "q0[3]", "obstacles[1].pose.position[2]",
// "gap.tol", ...) for a value out of range.
void validate(const Scenario& s);

}  // namespace distlab::cbf
