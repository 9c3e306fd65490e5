#pragma once
// The GAP metric between two posed shapes: Λ (eq. 3), D = sqrt(2Λ), differentiable witness
// points, gradients with respect to both poses, and the Euclidean baseline beside it.
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "distlab/collision/euclidean.hpp"
#include "distlab/gap/point_to_set.hpp"
#include "distlab/gap/solver.hpp"
#include "distlab/geometry/parallel.hpp"

namespace distlab {

enum class GapSolver { fixed_point,
                       newton };

// Defaults: the paper's robot experiment (h = 0.1, k = 2, ε = 0.01, σ = sqrt(1 − 2ε)) and a tight
// tolerance; `max_iter` 0 means the solver's default (Newton 100, fixed point 100000).
struct GapParams {
  double h = 0.1;
  int k = 2;
  double eps = 0.01;
  double sigma = 0.9899494936611665;
  double weight_margin = 0.01;
  double tol = 1e-10;
  int max_iter = 0;
  GapSolver solver = GapSolver::newton;
  bool gradient = true;
  // Also report the certified Euclidean distance (FCL checked by a duality gap). Off: the solver
  // starts from an uncertified double-precision GJK answer (gjk_distance, stopped at a relative
  // gap of kStartRelativeGap), which `euclidean` then holds (no gradients).
  bool euclidean = true;

  int iteration_limit() const { return max_iter > 0 ? max_iter : (solver == GapSolver::newton ? 100 : 100000); }
};

// With params.euclidean off, the start's GJK stops once its duality gap is below this fraction of
// the distance (or 1e-12 of the pair's size). Newton's start is the middle of GJK's points, and
// a* lies ~0.2 d beside it anyway: on the paper's polytope pairs GJK takes 2.3 instead of 4.0
// steps, Newton 4.8 instead of 4.7 (0.1: 2.8 and 4.7, 4% slower in bench_gap). A gap below 1
// still proves the shapes apart.
inline constexpr double kStartRelativeGap = 0.2;

// Throws InvalidInput naming "params.<name>" for a parameter out of range.
void check_params(const GapParams& params);

// One shape with its P2S functions and Euclidean geometry, built once and moved by set_pose.
class GapBody {
 public:
  GapBody(const Shape& shape, const Pose& pose, const GapParams& params,
          const P2SOptions& options = {}, const std::string& field = "shape");
  // The same sharing FCL geometry already built (a robot's elements: Robot::euclidean_shape).
  GapBody(const EuclideanShape& shape, const Pose& pose, const GapParams& params,
          const P2SOptions& options = {}, const std::string& field = "shape");
  void set_pose(const Pose& pose);
  const Pose& pose() const { return p2s_.pose(); }
  const PointToSet& p2s() const { return p2s_; }
  const EuclideanShape& euclidean() const { return euclid_; }
  double radius() const { return radius_; }  // of the shape's bounding ball
  double reach() const { return reach_; }    // largest distance of a shape point from its origin

 private:
  void place(const Pose& pose);  // the ball's radius and reach, then the pose
  PointToSet p2s_;
  EuclideanShape euclid_;
  double radius_ = 0, reach_ = 0;
};

struct GapResult {
  double lambda = 0;    // Λ, eq. (3)
  double distance = 0;  // D = sqrt(2Λ)
  Vec3 witness_a = Vec3::Zero();
  Vec3 witness_b = Vec3::Zero();
  int iterations = 0;
  bool converged = true;
  bool overlap = false;
  EuclideanResult euclidean;
  // false from gap_distance_warm (empty) and with params.euclidean off (uncertified GJK answer)
  bool euclidean_computed = true;
  // dD/d(v, ω) of each shape, world frame, ω about the shape's own origin (zero on overlap).
  Vec6 gradient_a = Vec6::Zero();
  Vec6 gradient_b = Vec6::Zero();
};

GapResult gap_distance(const GapBody& a, const GapBody& b, const GapParams& params);

// For tracking a moving pair (CBF rollouts): no FCL call; overlap decided by libccd; Newton
// starts at the given points (e.g. the previous step's witnesses), so it needs few steps.
// `euclidean` is left empty (euclidean_computed = false).
GapResult gap_distance_warm(const GapBody& a, const GapBody& b, const GapParams& params,
                            const Vec3& start_a, const Vec3& start_b);

// A tracked pair's state between gap_distance_tracked calls: the last solution (witnesses and
// their E derivatives) and the poses it was solved at. Default: nothing to continue from.
struct GapTrack {
  WitnessSolution last;
  Pose pose_a, pose_b;
  bool valid = false;
  // A plane normal (unit, A towards B) with A and B at least `margin` apart on either side at
  // those poses; the overlap test is skipped while the motion since cannot have closed it.
  Vec3 normal = Vec3::Zero();
  double margin = 0;
};

// gap_distance_warm from the start predict_witnesses gives for the bodies' current poses, Newton
// stopping on its error estimate (solve_predicted: on steps of ~1 mm and 1°, 0.9 Newton steps
// after the first evaluation against 2.6 from the old witnesses, witnesses within tol); updates
// `track`. An empty track (or one after an overlap or a failed solve) starts cold, as
// gap_distance does, and the next call warm from its witnesses.
GapResult gap_distance_tracked(const GapBody& a, const GapBody& b, const GapParams& params, GapTrack& track);

// A reference for the pose gradients of D where double cannot give one by finite differences:
// near contact (Euclidean distance ~1e-7, D ~ 1e-21) D's rounding in double is ~1e-9 relative
// (s = u·p − b ~ 1e-7 against |p| ~ 0.3), which a difference quotient divides by its step.
// Here every D is solved in long double (solve_newton's long-double overload, PointToSet::
// strict_at), with the poses moved in long double too: central differences of D along the 12
// pose coordinates (linear, then world-frame rotation about the shape's origin; the order of
// GapResult::gradient_a/b) with coordinate step `step`, starting from r's witness on A.
struct ExtendedGradient {
  Vec6 a = Vec6::Zero(), b = Vec6::Zero();
  double distance = 0;    // D at the given poses, solved in long double
  bool converged = true;  // every solve converged
};
// Throws InvalidInput("step") unless step is positive and finite.
ExtendedGradient gap_gradient_extended(const GapBody& a, const GapBody& b, const GapResult& r, double step);

// The former name of distlab::parallel_for (geometry/parallel.hpp), for the callers that still use it.
inline void parallel_indices(std::size_t n, unsigned threads, const std::function<void(std::size_t)>& fn) {
  parallel_for(n, threads, fn);
}

// Many pairs on all cores (threads = 0: hardware concurrency). Results in input order.
std::vector<GapResult> gap_distance_batch(
    const std::vector<std::pair<const GapBody*, const GapBody*>>& pairs, const GapParams& params,
    unsigned threads = 0);
// The same into the caller's storage (out.size() == pairs.size(), else InvalidInput "results"),
// e.g. reused from call to call. Each worker claims up to kBatchBlock consecutive pairs at a time
// and writes their results itself: claimed pair by pair (~2 µs each), the cores would pass the claim
// counter's cache line, and the neighbouring results' lines, to and fro on every pair.
void gap_distance_batch(std::span<const std::pair<const GapBody*, const GapBody*>> pairs,
                        const GapParams& params, std::span<GapResult> out, unsigned threads = 0);
inline constexpr std::size_t kBatchBlock = 32;

}  // namespace distlab
