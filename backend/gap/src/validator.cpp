#include "distlab/gap/validator.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

namespace distlab {
namespace {

struct Sample {
  double lambda_max;
  Vec3 p;
};

}  // namespace

ValidationReport validate_p2s(const PointToSet& original, int samples, std::uint64_t seed) {
  PointToSet p2s = original;
  p2s.set_pose(Pose{});
  const Ball ball = bounding_ball(p2s.shape());
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  auto random_dir = [&] {
    Vec3 d(normal(rng), normal(rng), normal(rng));
    return Vec3(d / std::max(d.norm(), 1e-300));
  };

  ValidationReport rep;
  rep.min_eigenvalue = INFINITY;
  std::vector<Sample> outside;
  auto evaluate = [&](const Vec3& p) -> double {
    const P2SValue v = p2s.strict(p, 2);
    ++rep.samples;
    if (p2s.contains(p)) {
      rep.max_inside_norm = std::max(rep.max_inside_norm, v.hessian.norm());
      return -INFINITY;
    }
    Eigen::SelfAdjointEigenSolver<Mat3> es;
    es.compute(v.hessian, Eigen::EigenvaluesOnly);  // computeDirect loses small eigenvalues
    const double lmax = es.eigenvalues()[2], lmin = es.eigenvalues()[0];
    // Eigenvalues carry an absolute rounding error of ~eps ‖H‖: below that, negative is zero.
    if (lmin < rep.min_eigenvalue) {
      rep.min_eigenvalue = lmin;
      rep.min_eigenvalue_tolerance = 64 * 2.2e-16 * std::max(std::abs(lmax), 1e-300);
    }
    if (lmax > rep.max_eigenvalue) {
      rep.max_eigenvalue = lmax;
      rep.worst_point = p;
    }
    return lmax;
  };
  // Points near the surface (support point plus an offset at scales from 1e-4 to 10 radii) and
  // points anywhere in a large ball; all scales matter: E's curvature peaks near the shape.
  for (int i = 0; i < samples; ++i) {
    Vec3 p;
    const double scale = ball.radius * std::pow(10.0, -4.0 + 5.0 * uniform(rng));
    if (i % 2 == 0) {
      p = support(p2s.shape(), random_dir()) + scale * random_dir();
    } else {
      p = ball.center + 4.0 * ball.radius * std::cbrt(uniform(rng)) * random_dir();
    }
    const double l = evaluate(p);
    if (std::isfinite(l)) outside.push_back({l, p});
  }
  // Refine the worst samples by a shrinking random search.
  std::sort(outside.begin(), outside.end(),
            [](const Sample& x, const Sample& y) { return x.lambda_max > y.lambda_max; });
  const size_t refine = std::min<size_t>(outside.size(), 8);
  for (size_t k = 0; k < refine; ++k) {
    Sample best = outside[k];
    double step = 0.05 * ball.radius;
    for (int it = 0; it < 300 && step > 1e-9 * ball.radius; ++it) {
      const Vec3 p = best.p + step * random_dir();
      const double l = evaluate(p);
      if (l > best.lambda_max) best = {l, p};
      else if (it % 20 == 19) step *= 0.5;
    }
  }
  if (!std::isfinite(rep.min_eigenvalue)) rep.min_eigenvalue = 0;
  std::ostringstream msg;
  if (rep.max_eigenvalue >= 1.0) {
    msg << "Property 2 fails: the Hessian of E_S has eigenvalue " << rep.max_eigenvalue
        << " >= 1 at (" << rep.worst_point.transpose()
        << ") in the shape frame; decrease eps, sigma or the weights";
  } else if (rep.min_eigenvalue < -rep.min_eigenvalue_tolerance) {
    msg << "Property 2 fails: E_S is not convex (eigenvalue " << rep.min_eigenvalue << ")";
  } else if (rep.max_inside_norm > 0) {
    msg << "Property 2 fails: the Hessian of E_S is not zero inside the set";
  } else {
    rep.ok = true;
    msg << "Property 2 holds on " << rep.samples << " samples: largest eigenvalue "
        << rep.max_eigenvalue;
  }
  rep.message = msg.str();
  return rep;
}

}  // namespace distlab
