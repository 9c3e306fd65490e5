#pragma once
// Every distance of a robot and its gradient in joint space: robot–obstacle and self pairs, the
// GAP metric D = sqrt(2Λ) (gap-differentiable-distance.txt, eq. 3) or the Euclidean distance
// (FCL), for one configuration or a batch of them. ∇_q D is exact: the pose gradients of D
// (GapResult::gradient_a/b, about each shape's origin) through the origins' point Jacobians,
// dD/dq = g_aᵀ J_a (+ g_bᵀ J_b for a self pair).
#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "distlab/gap/distance.hpp"
#include "distlab/robot/robot.hpp"

namespace distlab::robot {

enum class Metric { gap,
                    euclidean };
const char* to_string(Metric m);

// A convex obstacle fixed in the world.
struct Obstacle {
  std::string name;
  Shape shape;
  Pose pose;             // world
  P2SOptions options{};  // GAP weights / ρ ball (defaults of the gap library)
};

// Which pairs: robot–obstacle pairs (every collision element with every obstacle) and self pairs
// (Robot::self_pairs: elements of links at least two joints apart), then `allow`ed link pairs
// added and `deny`ed ones removed (link names; the same link twice names its own elements).
struct PairSelection {
  bool obstacles = true;
  bool self = false;
  std::vector<std::pair<std::string, std::string>> allow, deny;
};

struct RobotPair {
  int a;             // collision element of the robot (index into Robot::primitives())
  int b;             // obstacle index, or the second collision element of a self pair
  bool self;         // a self pair
  std::string name;  // "ELEMENT/OBSTACLE" or "ELEMENT/ELEMENT"
};

// The pairs of a selection, in the order every result uses: robot–obstacle pairs element by
// element (primitives() order), each with every obstacle in order; then the self pairs (i < j,
// lexicographic). Throws InvalidInput("pairs.allow[i]" / "pairs.deny[i]") for an unknown link.
std::vector<RobotPair> select_pairs(const Robot& robot, const std::vector<Obstacle>& obstacles,
                                    const PairSelection& selection);

// One pair's distance at one configuration (the CBF controller's per-pair record too).
struct PairDistance {
  double distance = 0;            // D (GAP) or the Euclidean distance; 0 on overlap
  double clearance = 0;           // the Euclidean distance where it was computed, else NaN
  Vec3 witness_a = Vec3::Zero();  // on the robot's element
  Vec3 witness_b = Vec3::Zero();  // on the obstacle (or the self pair's second element)
  // dD/d(v, ω) of the obstacle (world frame, ω about its origin): a moving obstacle's term of
  // dD/dt. Zero for self pairs (both elements are in the joint-space row) and on overlap.
  Vec6 obstacle_gradient = Vec6::Zero();
  bool overlap = false;
  int iterations = 0;  // GAP solver iterations (0 for Euclidean)
  bool converged = true;
  bool cold = false;  // GAP: solved from the Euclidean witnesses instead of warm-started
  // The CBF controller's gap.mode as_published: the converged D beside the early-stopped
  // `distance` it used; NaN otherwise.
  double converged_distance = std::numeric_limits<double>::quiet_NaN();
};

// GAP options of a robot's or an obstacle's shape. A box's violated half-spaces are mutually
// orthogonal, so its Hessian Σ W_i Φ''(s_i) u_i u_iᵀ has eigenvalues W_i Φ'' < W_i far from it:
// W_i = 1/(1 + margin), like the cylinder's terms, where the validator (validate_p2s) confirms
// Property 2 for that box and these params; the gap library's default 1/(m + margin), m = 3, is
// the bound for general polytopes and makes D three times flatter, and stays where the box's
// proportions break Property 2 near the ρ sphere (thin or large boxes against h). Given weights
// and other shapes: unchanged.
P2SOptions gap_body_options(const Shape& shape, P2SOptions options, const GapParams& params);

// Collision elements small against h (millimetres at h = 0.1: an IMU's box, a placeholder
// sphere, a finger's pad in a maker's URDF) can break Property 2 under any weights: over a shape
// far smaller than h, Φ(s) ≈ s³/(6h), so the Hessian's growth falls in proportion to h (the
// validator's advice). An element whose bounding radius is below kSmallElementShare · h and whose
// check fails takes its own h: kSmallElementMargin · h / (the largest eigenvalue found), rounded
// down to two significant digits (the warning gives it exactly), checked again, at most
// kSmallElementAttempts times. Each shape has its own e_S and E_S, which the GAP iteration and
// eq. 3 take as they are, so the element's D stays differentiable and vanishes on contact; it is
// sharper (closer to the Euclidean distance) around that element alone. An element that still
// fails keeps h, and the validation refuses it as before.
inline constexpr double kSmallElementShare = 0.25;
inline constexpr double kSmallElementMargin = 0.5;
inline constexpr int kSmallElementAttempts = 4;
// Elements large against h break it the other way (simple_humanoid's 1 m cylinder and its box
// mesh in Gepetto/example-robot-data): E_S's Hessian is unchanged when h grows with the shape, so
// at a fixed h a large shape can fail near its surface (at h = 0.1: a 1 m sphere 1.17, a 1 m
// capsule 1.29, simple_humanoid's box 1.14), and a smaller ε lowers that (the validator's advice).
// An element whose bounding radius is at least kLargeElementShare · h and whose check fails takes
// its own ε, halved (σ kept: σ² ≤ 1 − 2ε still holds) and checked again while the eigenvalue
// falls, kLargeElementAttempts checks in all (ε/16 the last). Measured: a 1 m cylinder holds at
// ε/4, a 2 m sphere at ε/8; a 5 m sphere needs more than ε/32 and keeps ε (the validation refuses
// it, as any element that still fails).
inline constexpr double kLargeElementShare = 3;
inline constexpr int kLargeElementAttempts = 5;

// The GAP parameters of one robot element (its shape and FCL geometry, Robot::euclidean_shape):
// `params`, or with its own h as above (`note` says so). `options`: the element's P2S options at
// given parameters. `checkpoint`, if given, is called before each check (it may throw to stop).
GapParams element_params(const EuclideanShape& shape, const GapParams& params,
                         const std::function<P2SOptions(const GapParams&)>& options, std::string& note,
                         const std::function<void()>& checkpoint = nullptr);

// The robot, the obstacles, the metric and the pairs, built once (GAP bodies, FCL geometry); read
// only after construction, so one model serves many threads, each with its own Workspace.
class DistanceModel {
 public:
  // Options of each body (robot elements and obstacles); default gap_body_options. The CBF
  // controller's as_published mode passes the published package's construction.
  using BodyOptions = std::function<P2SOptions(const Shape&, const P2SOptions& given)>;
  // Throws InvalidInput naming the field: "params.*" (check_params), "obstacles[i]...",
  // "pairs.allow[i]" / "pairs.deny[i]" (an unknown link). Building GAP bodies of large hulls
  // (their weights, element_params' checks) takes time: `checkpoint`, if given, is called before
  // each body and each check, and may throw to stop (the server's time limit).
  DistanceModel(std::shared_ptr<const Robot> robot, std::vector<Obstacle> obstacles, Metric metric,
                const GapParams& params, const PairSelection& selection, const BodyOptions& options = nullptr,
                const std::function<void()>& checkpoint = nullptr);

  const Robot& robot() const { return *robot_; }
  const std::shared_ptr<const Robot>& robot_ptr() const { return robot_; }
  const std::vector<Obstacle>& obstacles() const { return obstacles_; }
  Metric metric() const { return metric_; }
  const GapParams& params() const { return params_; }
  const std::vector<RobotPair>& pairs() const { return pairs_; }
  int dof() const { return robot_->dof(); }
  // Elements that took their own h (element_params), one line each, in primitives() order.
  const std::vector<std::string>& warnings() const { return warnings_; }

  // One thread's state: FK, the robot's bodies at their current poses, the obstacles at theirs
  // (the model's, or place_obstacles'), and one GapTrack per pair (the last solution, continued
  // along a sequence of configurations and obstacle poses).
  struct Workspace {
    Kinematics kinematics;
    std::vector<GapBody> robot_gap;
    std::vector<Pose> robot_pose;
    std::vector<Jac> robot_jac;         // Jacobian of each element's origin, fixed to its link
    std::vector<GapBody> obstacle_gap;  // GAP metric only
    std::vector<Pose> obstacle_pose;
    std::vector<GapTrack> tracks;
  };
  Workspace workspace() const;
  // A workspace from the model's pool (made when the pool is empty), its tracks empty and its
  // obstacles where its last user placed them (place_obstacles sets them); give it back with
  // recycle() so that a 1 kHz caller does not copy the bodies on every call.
  std::unique_ptr<Workspace> acquire() const;
  void recycle(std::unique_ptr<Workspace> w) const;
  // Moves w's obstacles to `poses` (one per obstacle, in obstacles() order; empty: the model's
  // own): a moving obstacle needs no new model, and its pairs' tracks continue. Only the obstacles
  // whose pose changed are moved. Throws InvalidInput("obstacles") for another count; the poses
  // are the caller's to check (finite, unit rotations).
  void place_obstacles(Workspace& w, std::span<const Pose> poses) const;
  const GapBody& obstacle_body(int j) const { return obstacle_gap_[j]; }  // at the model's pose
  const EuclideanShape& obstacle_shape(int j) const { return obstacle_euclid_[j]; }
  const EuclideanShape& robot_shape(int i) const { return robot_->euclidean_shape(i); }

  // Called per GAP pair after the exact solve, before the chain rule: may replace the result
  // (the as_published mode's early-stopped distance) and fill `out`'s extra fields.
  using Adjust = std::function<void(int pair, const GapBody& a, const GapBody& b, GapResult& g, PairDistance& out)>;

  // FK at q (checked: Robot::check_q), then every pair: out[p] and row p of grad (dD/dq).
  // `tracking`: GAP pairs continue from w.tracks (gap_distance_tracked; a warm solve that fails
  // is redone cold), else each is solved cold. Euclidean pairs ignore it.
  void evaluate(const VecQ& q, Workspace& w, bool tracking, std::span<PairDistance> out, GradQ& grad,
                const Adjust& adjust = nullptr) const;
  // The same after the caller's own robot.forward(q, w.kinematics).
  void evaluate_at(Workspace& w, bool tracking, std::span<PairDistance> out, GradQ& grad,
                   const Adjust& adjust = nullptr) const;

 private:
  std::shared_ptr<const Robot> robot_;
  std::vector<Obstacle> obstacles_;
  Metric metric_;
  GapParams params_;
  std::vector<RobotPair> pairs_;
  std::vector<std::string> warnings_;
  std::vector<GapBody> robot_gap_, obstacle_gap_;  // GAP metric only; robot_gap_ at the zero pose
  std::vector<EuclideanShape> obstacle_euclid_;    // the robot's: Robot::euclidean_shape
  struct Pool;
  std::shared_ptr<Pool> pool_;
};

// A batch: N configurations, P pairs, dof joints; arrays row-major in (configuration, pair, …)
// order, pairs in DistanceModel::pairs() order, q in the robot's joint order.
struct DistanceBatch {
  int n = 0, pairs = 0, dof = 0;
  std::vector<double> distance;          // (N, P)
  std::vector<double> jacobian;          // (N, P, dof): dD/dq
  std::vector<double> witness_robot;     // (N, P, 3), world
  std::vector<double> witness_obstacle;  // (N, P, 3), world: on the obstacle or the second element
  // (N, P, 6): PairDistance::obstacle_gradient, dD/d(v, ω) of the obstacle (0 for self pairs).
  std::vector<double> obstacle_gradient;
  std::vector<std::uint8_t> overlap;    // (N, P)
  std::vector<std::uint8_t> converged;  // (N, P)
  std::vector<int> iterations;          // (N, P)
  // The tracks after the last configuration: pass them as the next call's warm start.
  std::vector<GapTrack> tracks;
};

struct BatchOptions {
  unsigned threads = 0;  // 0: every core; at most the number of configurations
  bool tracking = true;  // GAP: each configuration continues from the one before (a trajectory)
  // Tracks to continue the first configuration from (a previous batch's `tracks`), or empty.
  std::span<const GapTrack> warm_start{};
  // The obstacles' poses for every configuration (DistanceModel::place_obstacles), or empty: the
  // model's.
  std::span<const Pose> obstacle_poses{};
  const std::atomic<bool>* cancel = nullptr;  // set: throws Cancelled between configurations
};

// Every pair at every configuration of q (n × dof, row-major). Threads take contiguous runs of
// configurations, each tracked along its run; the first run starts from warm_start, the others
// cold. Throws InvalidInput("q[i]") for a bad configuration, InvalidInput("warm_start") for tracks
// of another pair count.
DistanceBatch distances(const DistanceModel& model, std::span<const double> q, int n, const BatchOptions& options = {});

}  // namespace distlab::robot
