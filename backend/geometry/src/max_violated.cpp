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

int max_violated_halfspaces_bound(const MatX3& A) {
  const Eigen::Index n = A.rows();
  if (n < 3) return max_violated_halfspaces(A);
  // On the great circle {d : a_i . d = 0}, d(θ) = cos θ e1 + sin θ e2 and a_k . d = r_k cos(θ − φ_k):
  // row k is not strictly negative (a_k . d >= -kTol) on the closed arc |θ − φ_k| <= acos(−kTol/r_k),
  // or everywhere when r_k <= kTol. U(v) = #{k : a_k . v >= −kTol} = pos(v) + ties(v) bounds the
  // count of every cell at v (pos(v) + the ties' best half circle), so the largest U over the
  // arrangement's vertices bounds the largest count; it is that count where a vertex's ties lie in
  // one open half circle (e.g. two rows in general position).
  std::vector<double> start, end, candidates;
  int best = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 ai = A.row(i);
    const Vec3 e1 = ai.unitOrthogonal(), e2 = ai.cross(e1).normalized();
    start.clear();
    end.clear();
    candidates.clear();
    int always = 0;
    for (Eigen::Index k = 0; k < n; ++k) {
      const Vec3 ak = A.row(k);
      const double p = ak.dot(e1), q = ak.dot(e2), r = std::hypot(p, q);
      if (r <= kTol) {
        ++always;
        continue;
      }
      const double phi = std::atan2(q, p), half = std::acos(std::max(-1.0, -kTol / r));
      double s0 = phi - half;
      while (s0 < 0) s0 += 2 * std::numbers::pi;
      while (s0 >= 2 * std::numbers::pi) s0 -= 2 * std::numbers::pi;
      start.push_back(s0);
      end.push_back(s0 + 2 * half);
      if (ai.cross(ak).norm() > 1e-12)  // a vertex ±(a_i × a_k) of the arrangement on this circle
        for (double t : {phi + std::numbers::pi / 2, phi - std::numbers::pi / 2})
          candidates.push_back(t - 2 * std::numbers::pi * std::floor(t / (2 * std::numbers::pi)));
    }
    std::sort(start.begin(), start.end());
    std::sort(end.begin(), end.end());
    for (const double t : candidates) {
      // Closed arcs [s, e] (e < s + 2π, s in [0, 2π)) holding t: s <= t <= e, or s <= t + 2π <= e.
      const auto started = std::upper_bound(start.begin(), start.end(), t) - start.begin();
      const auto ended = std::lower_bound(end.begin(), end.end(), t) - end.begin();
      const auto wrapped = end.end() - std::lower_bound(end.begin(), end.end(), t + 2 * std::numbers::pi);
      best = std::max(best, always + static_cast<int>(started - ended + wrapped));
    }
  }
  return best > 0 ? best : max_violated_halfspaces(A);
}

}  // namespace distlab
