// The largest number of half-spaces one point can violate (the paper's m).
//
// Why counting directions is exact: let q be an interior point (a_i . q < b_i for all i).
// If p violates the rows V, then d = p - q has a_i . d > b_i - a_i . q > 0 for every i in V.
// Conversely if a_i . d > 0 for i in V, the point q + t d violates all of V for t large
// ("at infinity"). So the answer is the largest open-hemisphere count max_d #{i : a_i . d > 0}.
//
// Why the candidates suffice: the count is constant on each open cell of the arrangement of
// great circles {d : a_i . d = 0}, and every cell's closure has a vertex v = +-(a_i x a_j)
// (when two rows are not parallel). Next to v, rows with a_i . v > 0 stay positive and rows
// with a_i . v = 0 are positive exactly when a_i . u > 0 for the small tangent step u: the
// best cell at v is found by an open-half-circle count in the plane orthogonal to v.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "distlab/geometry/polytope.hpp"

namespace distlab {
namespace {

constexpr double kTol = 1e-9;

// Largest number of angles inside one open half circle. An optimal open half circle can be
// rotated until its first point sits on its start, so the windows [t_k, t_k + pi) suffice.
int best_half_circle(std::vector<double>& angles) {
  if (angles.empty()) return 0;
  std::sort(angles.begin(), angles.end());
  std::vector<double> ext;  // three turns, so every window is one contiguous range
  for (double shift : {-2 * std::numbers::pi, 0.0, 2 * std::numbers::pi})
    for (double a : angles) ext.push_back(a + shift);
  int best = 0;
  for (double a : angles) {
    const auto lo = std::lower_bound(ext.begin(), ext.end(), a - kTol);
    const auto hi = std::lower_bound(ext.begin(), ext.end(), a + std::numbers::pi - kTol);
    best = std::max(best, static_cast<int>(hi - lo));
  }
  return std::min(best, static_cast<int>(angles.size()));
}

}  // namespace

int max_violated_halfspaces(const MatX3& A) {
  const Eigen::Index n = A.rows();
  int best = 0;
  bool any_pair = false;
  std::vector<double> angles;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 ai = A.row(i);
    for (Eigen::Index j = i + 1; j < n; ++j) {
      const Vec3 c = ai.cross(A.row(j).transpose());
      const double cn = c.norm();
      if (cn <= 1e-12) continue;  // parallel rows meet in no arrangement vertex
      any_pair = true;
      const Vec3 v = c / cn;
      const Vec3& e1 = ai;  // with e2, a basis of the plane orthogonal to v
      const Vec3 e2 = v.cross(e1);
      int pos = 0, neg = 0;
      angles.clear();
      for (Eigen::Index k = 0; k < n; ++k) {
        const Vec3 ak = A.row(k);
        const double s = ak.dot(v);
        if (s > kTol) ++pos;
        else if (s < -kTol) ++neg;
        else if (ak.squaredNorm() > 0) angles.push_back(std::atan2(ak.dot(e2), ak.dot(e1)));
      }
      // +v counts `pos`, -v counts `neg`; the tangent plane and its best half circle are shared.
      best = std::max(best, std::max(pos, neg) + best_half_circle(angles));
    }
  }
  if (!any_pair && n > 0) {  // all rows parallel: d = +-a_0
    const Vec3 a0 = A.row(0);
    int pos = 0, neg = 0;
    for (Eigen::Index k = 0; k < n; ++k) {
      const double s = A.row(k).dot(a0);
      pos += s > kTol;
      neg += s < -kTol;
    }
    best = std::max(pos, neg);
  }
  return best;
}

}  // namespace distlab
