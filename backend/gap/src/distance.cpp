#include "distlab/gap/distance.hpp"

#include <algorithm>
#include <cmath>

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
      euclid_(shape),
      radius_(bounding_ball(shape).radius) {
  p2s_.set_pose(pose);
}

void GapBody::set_pose(const Pose& pose) { p2s_.set_pose(pose); }

namespace {

// Solves from the given starts and fills witness points, Λ, D and gradients.
void solve_into(GapResult& r, const GapBody& a, const GapBody& b, const GapParams& params,
                const Vec3& newton_a, const Vec3* newton_b, const Vec3& plain_start) {
  const int limit = params.iteration_limit();
  const WitnessSolution s =
      params.solver == GapSolver::newton
          ? solve_newton(a.p2s(), b.p2s(), newton_a, params.tol, limit, newton_b)
          : solve_fixed_point(a.p2s(), b.p2s(), plain_start, params.tol, limit);
  r.witness_a = s.a;
  r.witness_b = s.b;
  r.iterations = s.iterations;
  r.converged = s.converged;
  r.lambda = std::max(s.lambda, 0.0);
  r.distance = std::sqrt(2.0 * r.lambda);
  if (params.gradient && r.distance > 0) {
    lambda_gradients(s.a, s.b, a.pose(), b.pose(), r.gradient_a, r.gradient_b);
    r.gradient_a /= r.distance;  // dD = dΛ / D
    r.gradient_b /= r.distance;
  }
}

}  // namespace

GapResult gap_distance(const GapBody& a, const GapBody& b, const GapParams& params) {
  GapResult r;
  a.p2s().prefetch_vertices();  // the start's first support points need them at once
  b.p2s().prefetch_vertices();
  a.p2s().prefetch();  // the solver's rows arrive while the Euclidean start is computed
  b.p2s().prefetch();
  if (!params.euclidean) {
    // An uncertified GJK answer is a good enough start; near contact the certified path below
    // decides overlap with libccd.
    r.euclidean = gjk_distance(a.p2s().shape(), a.pose(), b.p2s().shape(), b.pose(),
                               a.radius() + b.radius());
    if (r.euclidean.distance > 1e-6 * (a.radius() + b.radius())) {
      r.euclidean_computed = false;
      const Vec3 middle = 0.5 * (r.euclidean.witness_a + r.euclidean.witness_b);
      solve_into(r, a, b, params, middle, nullptr, r.euclidean.witness_a);
      return r;
    }
  }
  r.euclidean = euclidean_distance(a.euclidean(), a.pose(), b.euclidean(), b.pose());
  if (r.euclidean.distance <= 0.0) {
    // Definition 2 on overlap: any common point; Λ = 0 (Proposition 3).
    const auto common = common_point(a.p2s().shape(), a.pose(), b.p2s().shape(), b.pose());
    r.overlap = true;
    r.witness_a = r.witness_b = common ? *common : r.euclidean.witness_a;
    return r;
  }
  // The plain iteration starts at the Euclidean witness on A, as in the paper (Section IV-A);
  // Newton starts between the Euclidean witnesses, where a* and b* lie (fewer steps: 4.5 against
  // 5.7 on the paper's random polytopes).
  const Vec3 middle = 0.5 * (r.euclidean.witness_a + r.euclidean.witness_b);
  solve_into(r, a, b, params, middle, nullptr, r.euclidean.witness_a);
  return r;
}

namespace {

// A plane normal to n (from A towards B) with A on one side and B on the other, more than 1e-6
// apart: a proof of no overlap from two support points. That is far beyond the overlap test's
// own tolerances (1e-9, collision/placed.hpp), which would then answer "no overlap" too.
bool separated_along(const GapBody& a, const GapBody& b, Vec3 n) {
  const double len = n.norm();
  if (!(len > 0) || !std::isfinite(len)) return false;
  n /= len;
  const Pose &pa = a.pose(), &pb = b.pose();
  const double a_max = n.dot(pa.to_world(support(a.p2s().shape(), pa.dir_to_local(n))));
  const double b_min = n.dot(pb.to_world(support(b.p2s().shape(), pb.dir_to_local(-n))));
  return b_min - a_max > 1e-6;
}

}  // namespace

GapResult gap_distance_warm(const GapBody& a, const GapBody& b, const GapParams& params,
                            const Vec3& start_a, const Vec3& start_b) {
  GapResult r;
  r.euclidean_computed = false;
  // Tracking: the previous witnesses' direction usually still separates the shapes, which
  // spares the overlap test (libccd), the most expensive part of a warm call.
  if (separated_along(a, b, start_b - start_a)) {
    solve_into(r, a, b, params, start_a, &start_b, start_a);
    return r;
  }
  if (const auto common = common_point(a.p2s().shape(), a.pose(), b.p2s().shape(), b.pose())) {
    r.overlap = true;
    r.witness_a = r.witness_b = *common;
    return r;
  }
  solve_into(r, a, b, params, start_a, &start_b, start_a);
  return r;
}

std::vector<GapResult> gap_distance_batch(
    const std::vector<std::pair<const GapBody*, const GapBody*>>& pairs, const GapParams& params,
    unsigned threads) {
  std::vector<GapResult> out(pairs.size());
  parallel_for(pairs.size(), threads,
               [&](std::size_t i) { out[i] = gap_distance(*pairs[i].first, *pairs[i].second, params); });
  return out;
}

}  // namespace distlab
