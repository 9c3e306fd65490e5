// GJK on the Minkowski difference B - A with a brute-force distance sub-algorithm: every
// candidate is an actual convex combination (weights clamped to >= 0), so witnesses always lie
// in A and B and the smallest candidate wins (no fragile Voronoi-region tests). Near
// convergence on curved shapes the simplices are long and thin (edges ~1e-6 against ~1), so the
// certified path runs in long double (in double it stalls at gaps around 1e-11); the GAP solver's
// start only needs a nearby point and runs the same algorithm in double.
#include "gjk.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace distlab::detail {
namespace {

template <class Real>
struct Gjk {
  using V3 = Eigen::Matrix<Real, 3, 1>;
  using M3 = Eigen::Matrix<Real, 3, 3>;

  struct Vertex {
    V3 w, a, b;  // w = b - a
  };

  struct Frame {
    const Placed& p;
    M3 R;
    V3 t;
    explicit Frame(const Placed& q) : p(q), R(q.R.cast<Real>()), t(q.t.cast<Real>()) {}
    V3 support(const V3& d) const {
      const Vec3 local = distlab::support(*p.shape, p.R.transpose() * d.template cast<double>());
      return R * local.template cast<Real>() + t;
    }
  };

  static Vertex support(const Frame& a, const Frame& b, const V3& n) {
    Vertex v;
    v.a = a.support(n);
    v.b = b.support(-n);
    v.w = v.b - v.a;
    return v;
  }

  // Weights of the origin's projection onto the affine hull of the k points, clamped to >= 0 and
  // renormalised; false only if the hull is degenerate.
  static bool project_origin(const V3* w, int k, Real* lam) {
    if (k == 1) {
      lam[0] = 1;
      return true;
    }
    const V3 e1 = w[1] - w[0];
    if (k == 2) {
      const Real ee = e1.squaredNorm();
      if (!(ee > 0)) return false;
      const Real t = std::clamp<Real>(-w[0].dot(e1) / ee, 0, 1);
      lam[0] = 1 - t;
      lam[1] = t;
      return true;
    }
    const V3 e2 = w[2] - w[0];
    if (k == 3) {
      const V3 n = e1.cross(e2);
      const Real nn = n.squaredNorm();
      if (!(nn > 0)) return false;
      const V3 z = n * (n.dot(w[0]) / nn);
      lam[0] = (w[1] - z).cross(w[2] - z).dot(n) / nn;
      lam[1] = (w[2] - z).cross(w[0] - z).dot(n) / nn;
      lam[2] = (w[0] - z).cross(w[1] - z).dot(n) / nn;
    } else {
      const V3 e3 = w[3] - w[0];
      const Real det = e1.dot(e2.cross(e3));
      if (!(det != 0)) return false;
      lam[1] = -w[0].dot(e2.cross(e3)) / det;
      lam[2] = -e1.dot(w[0].cross(e3)) / det;
      lam[3] = -e1.dot(e2.cross(w[0])) / det;
      lam[0] = 1 - lam[1] - lam[2] - lam[3];
    }
    Real sum = 0;
    for (int i = 0; i < k; ++i) sum += lam[i] = std::max<Real>(lam[i], 0);
    if (!(sum > 0) || !std::isfinite(static_cast<double>(sum))) return false;
    for (int i = 0; i < k; ++i) lam[i] /= sum;
    return true;
  }

  // Smallest-norm candidate over the subsets that contain the newest vertex (index n - 1); the
  // simplex keeps only the vertices with non-zero weight. Returns the squared norm.
  static Real reduce(Vertex* s, int& n, Real* lam) {
    Real best = std::numeric_limits<Real>::infinity();
    int best_mask = 0;
    Real best_lam[4] = {0, 0, 0, 0};
    const int newest = 1 << (n - 1);
    for (int mask = newest; mask < (1 << n); ++mask) {
      if (!(mask & newest)) continue;
      V3 w[4] = {V3::Zero(), V3::Zero(), V3::Zero(), V3::Zero()};
      int k = 0;
      for (int i = 0; i < n; ++i)
        if (mask & (1 << i)) w[k++] = s[i].w;
      Real l[4];
      if (!project_origin(w, k, l)) continue;
      V3 z = V3::Zero();
      for (int i = 0; i < k; ++i) z += l[i] * w[i];
      if (z.squaredNorm() < best) {
        best = z.squaredNorm();
        best_mask = mask;
        std::copy(l, l + k, best_lam);
      }
    }
    int m = 0, j = 0;
    for (int i = 0; i < n; ++i) {
      if (!(best_mask & (1 << i))) continue;
      if (best_lam[j] > 0) {
        lam[m] = best_lam[j];
        s[m++] = s[i];
      }
      ++j;
    }
    n = m;
    return best;
  }

  static GjkResult closest(const Placed& pa, const Placed& pb, const Vec3& n0, double gap_tol,
                           double zero_tol, int max_iter, double stop_above, double rel_gap) {
    const Frame a(pa), b(pb);
    Vertex s[4];
    Real lam[4] = {1, 0, 0, 0};
    const double n0n = n0.norm();
    const V3 n = (n0n > 0 ? Vec3(n0 / n0n) : Vec3::UnitX()).cast<Real>();
    s[0] = support(a, b, n);
    int count = 1;
    V3 z = s[0].w;
    GjkResult r;
    r.lower = static_cast<double>(n.dot(s[0].w));
    for (int it = 0; it < max_iter; ++it) {
      V3 ca = V3::Zero(), cb = V3::Zero();
      for (int i = 0; i < count; ++i) {
        ca += lam[i] * s[i].a;
        cb += lam[i] * s[i].b;
      }
      r.pa = ca.template cast<double>();
      r.pb = cb.template cast<double>();
      const Real zn = z.norm();
      r.upper = static_cast<double>(zn);
      if (r.upper <= zero_tol) {
        r.overlap = true;
        break;
      }
      const V3 dir = z / zn;
      const Vertex v = support(a, b, dir);
      r.lower = std::max(r.lower, static_cast<double>(dir.dot(v.w)));
      if (r.upper - r.lower <= gap_tol + rel_gap * r.upper || r.lower > stop_above || count == 4) break;
      Vertex trial[4];
      std::copy(s, s + count, trial);
      trial[count] = v;
      int trial_count = count + 1;
      Real trial_lam[4];
      if (!(reduce(trial, trial_count, trial_lam) < z.squaredNorm())) break;  // stalled
      std::copy(trial, trial + trial_count, s);
      std::copy(trial_lam, trial_lam + trial_count, lam);
      count = trial_count;
      z.setZero();
      for (int i = 0; i < count; ++i) z += lam[i] * s[i].w;
    }
    return r;
  }
};  // struct Gjk

}  // namespace

GjkResult gjk_closest(const Placed& a, const Placed& b, const Vec3& n0, double gap_tol,
                      double zero_tol, int max_iter, double stop_above) {
  return Gjk<long double>::closest(a, b, n0, gap_tol, zero_tol, max_iter, stop_above, 0.0);
}

GjkResult gjk_closest_double(const Placed& a, const Placed& b, const Vec3& n0, double gap_tol,
                             double zero_tol, int max_iter, double rel_gap) {
  return Gjk<double>::closest(a, b, n0, gap_tol, zero_tol, max_iter,
                              std::numeric_limits<double>::infinity(), rel_gap);
}

}  // namespace distlab::detail
