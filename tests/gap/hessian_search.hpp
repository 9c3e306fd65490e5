#pragma once
// An independent search for the largest Hessian eigenvalue of E_S, to check the Property 2
// validator against: the Hessian comes from central differences of the analytic gradient (not
// from eq. 18's Hessian code), and the search is a dense grid of directions × distances from
// the ρ centre (dense at the sphere ρ = 0) polished by Nelder–Mead, not the validator's
// feature-seeded compass search.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "distlab/gap/point_to_set.hpp"

namespace distlab::test {

// λ_max of the finite-difference Hessian at p (shape frame: p2s at the identity pose); −∞ in
// the set.
inline double fd_lambda_max(const PointToSet& p2s, const Vec3& p) {
  if (p2s.contains(p)) return -INFINITY;
  Mat3 fd;
  const double d = 1e-7 * (1 + p.norm());
  for (int c = 0; c < 3; ++c) {
    Vec3 dp = Vec3::Zero();
    dp[c] = d;
    fd.col(c) = (p2s.strict(p + dp, 1).gradient - p2s.strict(p - dp, 1).gradient) / (2 * d);
  }
  Eigen::SelfAdjointEigenSolver<Mat3> es(0.5 * (fd + fd.transpose()), Eigen::EigenvaluesOnly);
  return es.eigenvalues()[2];
}

struct SearchResult {
  double value = -INFINITY;
  Vec3 point = Vec3::Zero();
};

// Nelder–Mead maximisation of fd_lambda_max from x0 with an initial simplex of size `size`.
inline SearchResult nelder_mead(const PointToSet& p2s, const Vec3& x0, double size, int iterations) {
  std::array<Vec3, 4> x;
  std::array<double, 4> f;
  for (int i = 0; i < 4; ++i) {
    x[i] = x0;
    if (i > 0) x[i][i - 1] += size;
    f[i] = fd_lambda_max(p2s, x[i]);
  }
  for (int it = 0; it < iterations; ++it) {
    std::array<int, 4> o = {0, 1, 2, 3};
    std::sort(o.begin(), o.end(), [&](int a, int b) { return f[a] > f[b]; });  // best first
    const int worst = o[3];
    const Vec3 centroid = (x[o[0]] + x[o[1]] + x[o[2]]) / 3;
    const auto trial = [&](double t) { return Vec3(centroid + t * (x[worst] - centroid)); };
    const Vec3 r = trial(-1);
    const double fr = fd_lambda_max(p2s, r);
    if (fr > f[o[0]]) {
      const Vec3 e = trial(-2);
      const double fe = fd_lambda_max(p2s, e);
      if (fe > fr) x[worst] = e, f[worst] = fe;
      else x[worst] = r, f[worst] = fr;
    } else if (fr > f[o[2]]) {
      x[worst] = r, f[worst] = fr;
    } else {
      const Vec3 c = trial(0.5);
      const double fc = fd_lambda_max(p2s, c);
      if (fc > f[worst]) {
        x[worst] = c, f[worst] = fc;
      } else {
        for (int i = 1; i < 4; ++i) {
          x[o[i]] = x[o[0]] + 0.5 * (x[o[i]] - x[o[0]]);
          f[o[i]] = fd_lambda_max(p2s, x[o[i]]);
        }
      }
    }
  }
  SearchResult best;
  for (int i = 0; i < 4; ++i)
    if (f[i] > best.value) best = {f[i], x[i]};
  return best;
}

// Largest λ_max found on a grid of `directions` Fibonacci directions around the ρ centre, at
// distances dense around the ρ radius R and spread out to 64 R, then Nelder–Mead from the
// `starts` best grid points. p2s must be at the identity pose.
inline SearchResult independent_max(const PointToSet& p2s, int directions = 3000, int starts = 12) {
  const Vec3 c = p2s.rho_ball().center;
  const double R = p2s.rho_ball().radius;
  std::vector<double> radii;
  for (double t : {-3e-2, -1e-2, -3e-3, -1e-3, -3e-4, -1e-4, 0.0, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2})
    radii.push_back(R * (1 + t));
  for (double s = 0.3; s <= 64; s *= 1.25) radii.push_back(R * s);
  std::vector<SearchResult> grid;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < directions; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / directions, rr = std::sqrt(1.0 - z * z);
    const Vec3 w(rr * std::cos(golden * i + 0.3), rr * std::sin(golden * i + 0.3), z);
    for (double r : radii) {
      const Vec3 p = c + r * w;
      grid.push_back({fd_lambda_max(p2s, p), p});
    }
  }
  std::partial_sort(grid.begin(), grid.begin() + starts, grid.end(),
                    [](const SearchResult& a, const SearchResult& b) { return a.value > b.value; });
  SearchResult best = grid[0];
  for (int s = 0; s < starts; ++s)
    for (double size : {1e-2 * R, 1e-3 * R}) {
      const SearchResult r = nelder_mead(p2s, grid[static_cast<size_t>(s)].point, size, 400);
      if (r.value > best.value) best = r;
    }
  return best;
}

}  // namespace distlab::test
