#include "distlab/gap/distance.hpp"

#include <algorithm>
#include <cmath>
#include <thread>

#include "distlab/geometry/error.hpp"
#include "distlab/geometry/parallel.hpp"

namespace distlab {
namespace {

P2SOptions with_margin(P2SOptions options, const GapParams& params) {
  options.weight_margin = params.weight_margin;
  return options;
}

}  // namespace

void check_params(const GapParams& p) {
  BaseFunction(p.h, p.k);  // NOLINT(bugprone-unused-raii): built only for its checks of h and k
  auto positive = [](double v, const char* field, double upper = INFINITY) {
    if (!std::isfinite(v) || v <= 0 || v >= upper)
      throw InvalidInput(std::string("params.") + field,
                         std::string(field) + " must be finite, > 0" +
                             (std::isfinite(upper) ? " and < " + std::to_string(upper) : "") +
                             ", got " + std::to_string(v));
  };
  positive(p.eps, "eps", 0.5);
  positive(p.sigma, "sigma", 1.0);
  positive(p.weight_margin, "weight_margin");
  positive(p.tol, "tol", 1.0);
  if (p.max_iter < 0 || p.max_iter > 10'000'000)
    throw InvalidInput("params.max_iter", "max_iter must be in [0, 10000000] (0: default)");
}

GapBody::GapBody(const Shape& shape, const Pose& pose, const GapParams& params,
                 const P2SOptions& options, const std::string& field)
    : p2s_(shape, BaseFunction(params.h, params.k), StrictParams{params.eps, params.sigma},
           with_margin(options, params), field),
      euclid_(shape) {  // after p2s_, whose checks name the field
  place(pose);
}

GapBody::GapBody(const EuclideanShape& shape, const Pose& pose, const GapParams& params,
                 const P2SOptions& options, const std::string& field)
    : p2s_(shape.shape(), BaseFunction(params.h, params.k), StrictParams{params.eps, params.sigma},
           with_margin(options, params), field),
      euclid_(shape) {
  place(pose);
}

void GapBody::place(const Pose& pose) {
  const Ball ball = bounding_ball(p2s_.shape());
  radius_ = ball.radius;
  reach_ = ball.center.norm() + ball.radius;
  p2s_.set_pose(pose);
}

void GapBody::set_pose(const Pose& pose) { p2s_.set_pose(pose); }

namespace {

// Solves from the given starts and fills witness points, Λ, D and gradients; `keep`: where the
// solution itself goes (tracking: the track's own, written in place rather than copied there);
// `predicted`: Newton's starts are that prediction (solve_predicted).
void solve_into(GapResult& r, const GapBody& a, const GapBody& b, const GapParams& params,
                const Vec3& newton_a, const Vec3* newton_b, const Vec3& plain_start,
                WitnessSolution* keep = nullptr, const Prediction* predicted = nullptr) {
  const int limit = params.iteration_limit();
  WitnessSolution local;
  WitnessSolution& s = keep ? *keep : local;
  if (params.solver != GapSolver::newton) s = solve_fixed_point(a.p2s(), b.p2s(), plain_start, params.tol, limit);
  else if (predicted) solve_predicted(a.p2s(), b.p2s(), *predicted, params.tol, limit, s);
  else s = solve_newton(a.p2s(), b.p2s(), newton_a, params.tol, limit, newton_b);
  r.witness_a = s.a;
  r.witness_b = s.b;
  r.iterations = s.iterations;
  r.converged = s.converged;
  r.lambda = std::max(s.lambda, 0.0);
  r.distance = std::sqrt(2.0 * r.lambda);
  if (params.gradient && r.distance > 0) {
    lambda_gradients(s, a.pose(), b.pose(), r.gradient_a, r.gradient_b);
    const double inverse = 1 / r.distance;  // dD = dΛ / D
    r.gradient_a *= inverse;
    r.gradient_b *= inverse;
  }
}

// Definition 2 on overlap: any common point (r.euclidean's witness); Λ = 0 (Proposition 3).
GapResult& overlapping(GapResult& r) {
  r.overlap = true;
  r.witness_a = r.witness_b = r.euclidean.witness_a;
  return r;
}

}  // namespace

GapResult gap_distance(const GapBody& a, const GapBody& b, const GapParams& params) {
  GapResult r;
  a.p2s().prefetch_vertices();  // the start's first support points need them at once
  b.p2s().prefetch_vertices();
  a.p2s().prefetch();  // the solver's rows arrive while the Euclidean start is computed
  b.p2s().prefetch();
  if (!params.euclidean) {
    // An uncertified GJK answer is a good enough start, stopped at a 20% duality gap
    // (kStartRelativeGap). The same GJK settles a clear overlap
    // with a checked common point (the certified path's answer, distance 0, by the same test);
    // near contact the certified path below decides with FCL and libccd.
    const PointToSet &pa = a.p2s(), &pb = b.p2s();
    const GjkAnswer g =
        gjk_distance_or_common_point(pa.shape(), pa.rotation(), pa.pose().position, pb.shape(), pb.rotation(),
                                     pb.pose().position, a.radius() + b.radius(), kStartRelativeGap);
    if (g.common) {
      r.euclidean.witness_a = r.euclidean.witness_b = *g.common;
      return overlapping(r);
    }
    r.euclidean = g.nearest;
    if (r.euclidean.distance > 1e-6 * (a.radius() + b.radius())) {
      r.euclidean_computed = false;
      const Vec3 middle = 0.5 * (r.euclidean.witness_a + r.euclidean.witness_b);
      solve_into(r, a, b, params, middle, nullptr, r.euclidean.witness_a);
      return r;
    }
  }
  r.euclidean = euclidean_distance(a.euclidean(), a.pose(), b.euclidean(), b.pose());
  // On overlap its witness is already common_point's answer (euclidean.hpp).
  if (r.euclidean.distance <= 0.0) return overlapping(r);
  // The plain iteration starts at the Euclidean witness on A, as in the paper (Section IV-A);
  // Newton starts between the Euclidean witnesses, where a* and b* lie (fewer steps: 4.5 against
  // 5.7 on the paper's random polytopes).
  const Vec3 middle = 0.5 * (r.euclidean.witness_a + r.euclidean.witness_b);
  solve_into(r, a, b, params, middle, nullptr, r.euclidean.witness_a);
  return r;
}

namespace {

// The gap between A and B along n (made unit, from A towards B): the distance between the two
// supporting planes normal to n, from two support points; -inf for a zero or non-finite n.
double gap_along(const GapBody& a, const GapBody& b, Vec3& n) {
  const double len = n.norm();
  if (!(len > 0) || !std::isfinite(len)) return -INFINITY;
  n /= len;
  const Pose &pa = a.pose(), &pb = b.pose();
  const double a_max = n.dot(pa.to_world(support(a.p2s().shape(), pa.dir_to_local(n))));
  const double b_min = n.dot(pb.to_world(support(b.p2s().shape(), pb.dir_to_local(-n))));
  return b_min - a_max;
}

// A gap above 1e-6 is a proof of no overlap, far beyond the overlap test's own tolerances (1e-9,
// collision/placed.hpp), which would then answer "no overlap" too.
constexpr double kProvedApart = 1e-6;

// How far a point of the body can have moved from pose `from` to its current one: the
// translation plus the chord 2 sin(θ/2) of the rotation at the body's reach.
double motion_bound(const GapBody& body, const Pose& from) {
  const Quat turn = body.pose().rotation * from.rotation.conjugate();
  return (body.pose().position - from.position).norm() + 2 * turn.vec().norm() * body.reach();
}

// gap_distance_warm, keeping the solution in `keep` (when one is solved for); `track`: the
// separating plane, reused while the motion since cannot have closed its gap, else renewed;
// `predicted`: as solve_into's.
GapResult warm(const GapBody& a, const GapBody& b, const GapParams& params, const Vec3& start_a,
               const Vec3& start_b, WitnessSolution* keep, GapTrack* track = nullptr, const Prediction* predicted = nullptr) {
  GapResult r;
  r.euclidean_computed = false;
  // Tracking: the previous witnesses' direction usually still separates the shapes, which
  // spares the overlap test (libccd), the most expensive part of a warm call.
  double gap = -INFINITY;
  Vec3 n = start_b - start_a;
  if (track && track->margin > 0) {
    gap = track->margin - motion_bound(a, track->pose_a) - motion_bound(b, track->pose_b);
    n = track->normal;
  }
  if (!(gap > kProvedApart)) n = start_b - start_a, gap = gap_along(a, b, n);
  if (track) track->normal = n, track->margin = gap;
  if (gap > kProvedApart) {
    solve_into(r, a, b, params, start_a, &start_b, start_a, keep, predicted);
    return r;
  }
  if (const auto common = common_point(a.p2s().shape(), a.pose(), b.p2s().shape(), b.pose())) {
    r.overlap = true;
    r.witness_a = r.witness_b = *common;
    if (keep) *keep = WitnessSolution{};  // nothing solved: nothing to continue from
    return r;
  }
  solve_into(r, a, b, params, start_a, &start_b, start_a, keep, predicted);
  return r;
}

}  // namespace

GapResult gap_distance_warm(const GapBody& a, const GapBody& b, const GapParams& params,
                            const Vec3& start_a, const Vec3& start_b) {
  return warm(a, b, params, start_a, start_b, nullptr);
}

GapResult gap_distance_tracked(const GapBody& a, const GapBody& b, const GapParams& params, GapTrack& track) {
  if (!track.valid) {
    GapResult r = gap_distance(a, b, params);
    track.last = WitnessSolution{};
    track.last.a = r.witness_a, track.last.b = r.witness_b;  // no derivatives: the next call starts here
    track.margin = 0;                                        // no plane at these poses
    track.pose_a = a.pose(), track.pose_b = b.pose();
    track.valid = !r.overlap && r.converged;
    return r;
  }
  Vec3 start_a = track.last.a, start_b = track.last.b;
  Prediction prediction;
  const bool predicted =
      track.last.evaluated && predict_witnesses(track.last, track.pose_a, track.pose_b, a.pose(), b.pose(),
                                                start_a, start_b, &prediction);
  // The solution goes to track.last in place (read above, before the solve).
  GapResult r = warm(a, b, params, start_a, start_b, &track.last, &track, predicted ? &prediction : nullptr);
  track.pose_a = a.pose(), track.pose_b = b.pose();
  track.valid = !r.overlap && r.converged;
  return r;
}

ExtendedGradient gap_gradient_extended(const GapBody& a, const GapBody& b, const GapResult& r, double step) {
  using L = long double;
  // Well below long double's rounding of Λ's witnesses; the solver's relative stop rule answers
  // to the local length near contact.
  constexpr L kTol = 1e-18L;
  if (!(step > 0) || !std::isfinite(step)) throw InvalidInput("step", "must be a positive finite number");
  ExtendedGradient out;
  const PoseT<L> base_a = PoseT<L>::from(a.pose()), base_b = PoseT<L>::from(b.pose());
  const Vec3T<L> start = r.witness_a.cast<L>();
  auto distance = [&](const PoseT<L>& pa, const PoseT<L>& pb) {
    const auto s = solve_newton(PosedP2S<L>{a.p2s(), pa}, PosedP2S<L>{b.p2s(), pb}, start, kTol, 100);
    out.converged = out.converged && s.converged;
    return std::sqrt(2 * std::max(s.lambda, L(0)));
  };
  out.distance = static_cast<double>(distance(base_a, base_b));
  const L h = step;
  for (int which = 0; which < 2; ++which) {
    for (int c = 0; c < 6; ++c) {
      L d[2];
      for (int side = 0; side < 2; ++side) {
        PoseT<L> pa = base_a, pb = base_b;
        PoseT<L>& q = which == 0 ? pa : pb;
        const L x = side == 0 ? h : -h;
        if (c < 3) q.position[c] += x;
        else q.rotation = Eigen::Quaternion<L>(Eigen::AngleAxis<L>(x, Vec3T<L>::Unit(c - 3))) * q.rotation;
        d[side] = distance(pa, pb);
      }
      (which == 0 ? out.a : out.b)[c] = static_cast<double>((d[0] - d[1]) / (2 * h));
    }
  }
  return out;
}

std::vector<GapResult> gap_distance_batch(
    const std::vector<std::pair<const GapBody*, const GapBody*>>& pairs, const GapParams& params,
    unsigned threads) {
  std::vector<GapResult> out(pairs.size());
  gap_distance_batch(pairs, params, out, threads);
  return out;
}

void gap_distance_batch(std::span<const std::pair<const GapBody*, const GapBody*>> pairs,
                        const GapParams& params, std::span<GapResult> out, unsigned threads) {
  if (out.size() != pairs.size())
    throw InvalidInput("results", "room for " + std::to_string(out.size()) + " results, " +
                                      std::to_string(pairs.size()) + " pairs");
  // Blocks of up to kBatchBlock pairs, at least 8 per worker (short batches, e.g. the server's
  // chunks of 64, still use every core and end together).
  const std::size_t n = pairs.size(), workers = threads ? threads : std::max(1u, std::thread::hardware_concurrency());
  const std::size_t block = std::clamp<std::size_t>(n / (8 * workers), 1, kBatchBlock);
  parallel_for((n + block - 1) / block, threads, [&](std::size_t k) {
    for (std::size_t i = k * block; i < std::min(n, (k + 1) * block); ++i)
      out[i] = gap_distance(*pairs[i].first, *pairs[i].second, params);
  });
}

}  // namespace distlab
