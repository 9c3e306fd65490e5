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

#include <Eigen/Eigenvalues>

#include "distlab/geometry/parallel.hpp"
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

double max_violated_eigenvalue_bound(const MatX3& A, const VecX& w) {
  const Eigen::Index n = A.rows();
  // On the great circle {d : a_i . d = 0}, d(θ) = cos θ e1 + sin θ e2 and a_k . d = r_k cos(θ − φ_k):
  // row k is not strictly negative (a_k . d >= -kTol) on the closed arc |θ − φ_k| <= acos(−kTol/r_k),
  // or everywhere when r_k <= kTol. The cells around a vertex v violate the rows positive at v and,
  // of the rows tied there (whose circles pass through v), those in one open half plane of the
  // tangent directions (as in max_violated_halfspaces). A sweep along each circle keeps the sum
  // over the arcs holding the current angle; at a vertex the tied rows are taken out of it and
  // put back one tangent half circle at a time ([start − kTol, start + π − kTol), as in
  // best_half_circle: never fewer rows than a cell has, up to rows within kTol of antipodal).
  // The sum only grows with its set (its terms are PSD), so the largest λ_max found bounds
  // every point's.
  struct Event {
    double angle;
    int kind;  // 0: an arc starts, 1: a vertex, 2: an arc ends (closed arcs: ends after vertices)
    Eigen::Index row;
    bool operator<(const Event& o) const { return angle != o.angle ? angle < o.angle : kind < o.kind; }
  };
  const auto term = [&](Eigen::Index k) -> Mat3 {
    const Vec3 a = A.row(k);
    return w[k] * a * a.transpose();
  };
  const auto largest = [](const Mat3& m) {
    return Eigen::SelfAdjointEigenSolver<Mat3>().computeDirect(m, Eigen::EigenvaluesOnly).eigenvalues()[2];
  };
  constexpr double kTurn = 2 * std::numbers::pi;
  std::vector<double> best_of(static_cast<std::size_t>(n), 0.0);
  parallel_for(static_cast<std::size_t>(n), 0, [&](std::size_t circle) {
    const auto i = static_cast<Eigen::Index>(circle);
    const Vec3 ai = A.row(i);
    const Vec3 e1 = ai.unitOrthogonal(), e2 = ai.cross(e1).normalized();
    std::vector<Event> events;
    events.reserve(static_cast<std::size_t>(5 * n));
    std::vector<Eigen::Index> always;  // rows parallel to a_i: tied at every vertex of the circle
    std::vector<char> active(static_cast<std::size_t>(n), 0);
    Mat3 sum = Mat3::Zero();
    for (Eigen::Index k = 0; k < n; ++k) {
      const Vec3 ak = A.row(k);
      const double p = ak.dot(e1), q = ak.dot(e2), r = std::hypot(p, q);
      if (r <= kTol) {
        always.push_back(k);
        continue;
      }
      const double phi = std::atan2(q, p), half = std::acos(std::max(-1.0, -kTol / r));
      const double s0 = phi - half - kTurn * std::floor((phi - half) / kTurn), s1 = s0 + 2 * half;
      events.push_back({s0, 0, k});
      if (s1 < kTurn) {
        events.push_back({s1, 2, k});
      } else {  // wraps: [s0, 2π) and [0, s1 − 2π]
        events.push_back({0.0, 0, k});
        events.push_back({s1 - kTurn, 2, k});
      }
      if (ai.cross(ak).norm() > 1e-12)  // a vertex ±(a_i × a_k) of the arrangement on this circle
        for (double t : {phi + std::numbers::pi / 2, phi - std::numbers::pi / 2})
          events.push_back({t - kTurn * std::floor(t / kTurn), 1, k});
    }
    std::sort(events.begin(), events.end());
    double best = 0;
    std::vector<Eigen::Index> tied;
    std::vector<std::pair<double, Eigen::Index>> around;  // tied rows by tangent angle at v
    std::size_t next_vertex = 0;                          // vertex events before it were grouped
    for (std::size_t e = 0; e < events.size(); ++e) {
      const Event& ev = events[e];
      if (ev.kind == 1 && e < next_vertex) continue;
      if (ev.kind != 1) {
        const Mat3 t = term(ev.row);
        if (ev.kind == 0 && !active[ev.row]++) sum += t;
        else if (ev.kind == 2 && !--active[ev.row]) sum -= t;
        continue;
      }
      // The vertices within kTol of this angle are one vertex: their rows are its tied rows.
      tied.assign(always.begin(), always.end());
      tied.push_back(ev.row);
      next_vertex = e + 1;
      for (std::size_t f = e + 1; f < events.size() && events[f].angle <= ev.angle + kTol; ++f)
        if (events[f].kind == 1) {
          tied.push_back(events[f].row);
          next_vertex = f + 1;
        }
      std::sort(tied.begin(), tied.end());
      tied.erase(std::unique(tied.begin(), tied.end()), tied.end());
      if (tied.size() <= 2 && always.size() == 1) {  // a_i and a_k cross: both fit one half circle
        best = std::max(best, largest(sum + (active[ev.row] ? Mat3::Zero() : term(ev.row)) + term(i)));
        continue;
      }
      Mat3 base = sum;
      for (Eigen::Index k : tied)
        if (active[k]) base -= term(k);
      const Vec3 v = std::cos(ev.angle) * e1 + std::sin(ev.angle) * e2, along = v.cross(ai);
      around.clear();
      for (Eigen::Index k : tied) around.emplace_back(std::atan2(A.row(k).dot(along), A.row(k).dot(ai)), k);
      std::sort(around.begin(), around.end());
      for (const auto& [start, unused] : around) {
        Mat3 window = base;
        for (const auto& [angle, k] : around) {
          double offset = angle - start;
          offset -= kTurn * std::floor(offset / kTurn);
          if (offset < std::numbers::pi - kTol || offset >= kTurn - kTol) window += term(k);
        }
        best = std::max(best, largest(window));
      }
    }
    best_of[circle] = best;
  });
  double best = n > 0 ? *std::max_element(best_of.begin(), best_of.end()) : 0.0;
  if (!(best > 0)) {  // no arrangement vertex (all rows parallel): every row at once bounds it
    Mat3 all = Mat3::Zero();
    for (Eigen::Index k = 0; k < n; ++k) all += term(k);
    best = largest(all);
  }
  // Rounding of the running sums and of the closed-form eigenvalues: far below this allowance.
  return best * (1 + 1e-9) + 1e-12 * w.sum();
}

}  // namespace distlab
