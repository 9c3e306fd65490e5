#pragma once
// The CBF-QP controller of the corridor experiment (paper Section IV-B, franka-corridor.md):
//   min ½uᵀHu + fᵀu,  H = J_rᵀJ_r + λI,  f = J_rᵀ K r
//   s.t. ∇_q D_ij · u ≥ −η (D_ij − δ)   for robot–obstacle and self-collision pairs (eq. 7),
//        u ≥ −η_q (q − q_min),  −u ≥ −η_q (q_max − q)   (joint limits),
// with D the GAP distance sqrt(2Λ) or the Euclidean distance (FCL).
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "distlab/cbf/qp.hpp"
#include "distlab/cbf/rows.hpp"
#include "distlab/cbf/scenario.hpp"

namespace distlab::cbf {

// The pairs and their per-step records are the robot module's (DistanceModel).
using PairInfo = robot::RobotPair;
using PairSample = robot::PairDistance;

struct StepTiming {       // microseconds, steady_clock
  double kinematics = 0;  // FK, Jacobians, task function
  double distance = 0;    // poses, every pair's distance and gradient, chain rule to ∇_q D
  double qp = 0;          // assembling and solving the QP (and the relaxed one if needed)
  double step = 0;        // all of the above
  double audit = 0;       // GAP only: true Euclidean clearance of every pair (not control)
  double field = 0;       // Kelvin fields: h and ∇_q h at every control point (part of step)
};

struct StepOutput {
  VecQ u;
  Vec6 r = Vec6::Zero();
  double task_error = 0;  // ‖r‖
  std::vector<PairSample> pairs;
  double min_clearance = 0;  // min over pairs of the true Euclidean clearance
  QpStatus status = QpStatus::optimal;
  bool relaxed = false;  // the QP was infeasible; u solves the slack relaxation
  bool held = false;     // even the relaxation failed; u = 0
  double slack = 0;
  int active_rows = 0;
  std::vector<FieldPointSample> field_points;  // per field row (FieldBarrier: field-major)
  std::vector<int> active;                     // active QP rows: pair p is row p, field row r is pairs + r,
                                               // then u_i ≥ … (lower joint limit of joint i) at
                                               // pairs + field rows + i, upper at pairs + field rows + dof + i
  std::vector<double> multiplier;              // the active rows' multipliers, same order
  bool clipped = false;                        // u was clipped to the scenario's velocity limits
  StepTiming timing;
};

// Task function r(q) and its Jacobian (franka-corridor.md, "Controller").
struct Task {
  Vec6 r;
  Eigen::Matrix<double, 6, Eigen::Dynamic> J;
};
Task task_function(const Kinematics& k, const Robot& robot, const Pose& target);

// gap.mode as_published (scenario.hpp): the published package's P2S options for a shape, and
// its distance: plain iteration from B's centre (the ρ ball's centre), stopped at the first
// step below params.tol or after params.max_iter, D = sqrt(max(2Λ, 0)) at that iterate, with
// the envelope gradients there.
P2SOptions published_options(const Shape& shape);
GapResult published_distance(const GapBody& a, const GapBody& b, const GapParams& params);

class CbfController {
 public:
  // Building the distance model (a GAP body per element and obstacle, their Property 2 checks)
  // calls `checkpoint`, if given, before each body and check (DistanceModel); it may throw, e.g.
  // Cancelled, to stop.
  CbfController(const Scenario& scenario, Metric metric, const std::function<void()>& checkpoint = nullptr);
  ~CbfController();
  CbfController(const CbfController&) = delete;
  CbfController& operator=(const CbfController&) = delete;

  const std::vector<PairInfo>& pairs() const;
  const Robot& robot() const { return *robot_; }
  Metric metric() const { return metric_; }

  // One control step at q. `audit`: also compute the true Euclidean clearance of every pair
  // (free for the Euclidean metric; extra FCL calls for GAP, timed separately). Throws
  // FieldUndefined when a control point is where h is not defined (inside an object).
  StepOutput step(const VecQ& q, bool audit = true);

  // The distance rows at q without the QP (for tests): row i is ∇_q D of pair i.
  void distances(const VecQ& q, std::vector<PairSample>& samples, GradQ& grad);
  // The rows C u ≥ d of the QP at q (cbf_rows), as step() builds them, continuing the same tracks.
  void rows(const VecQ& q, Eigen::MatrixXd& C, Eigen::VectorXd& d);
  const robot::DistanceModel& model() const;
  // The Kelvin field rows (nullptr when the scenario has no fields).
  const FieldBarrier* barrier() const;
  int field_rows() const;

  void reset_warm_start();
  const Scenario& scenario() const { return scenario_; }

 private:
  struct Impl;
  void compute_pairs(std::vector<PairSample>& samples, GradQ& grad);  // at impl_'s kinematics
  Scenario scenario_;
  Metric metric_;
  std::shared_ptr<const Robot> robot_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace distlab::cbf
