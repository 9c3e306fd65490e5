// Property 2 by targeted maximisation of λ_max(∂²E_S), with a verdict cache (validator.hpp).
#include "distlab/gap/validator.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <sstream>
#include <utility>
#include <vector>

#include "distlab/geometry/overloaded.hpp"
#include "exact_key_cache.hpp"

namespace distlab {
namespace {

// ---------------------------------------------------------------------------------------------
// The verdict cache: exact keys (the defining numbers' bytes), least recently used out first.

using detail::append_bytes;

std::string cache_key(const PointToSet& p2s, int samples, std::uint64_t seed) {
  std::string key;
  const Shape& shape = p2s.shape();
  const std::size_t kind = shape.index();
  append_bytes(key, &kind, sizeof kind);
  std::visit(Overloaded{[&](const Polytope& p) {
                          const Eigen::Index n = p.A.rows();
                          append_bytes(key, &n, sizeof n);
                          append_bytes(key, p.A.data(), sizeof(double) * static_cast<std::size_t>(p.A.size()));
                          append_bytes(key, p.b.data(), sizeof(double) * static_cast<std::size_t>(n));
                        },
                        [&](const Box& b) { append_bytes(key, b.size.data(), 3 * sizeof(double)); },
                        [&](const Sphere& s) { append_bytes(key, s.radius); },
                        [&](const Cylinder& c) {
                          append_bytes(key, c.radius);
                          append_bytes(key, c.height);
                        },
                        [&](const Capsule& c) {
                          append_bytes(key, c.radius);
                          append_bytes(key, c.height);
                        }},
             shape);
  const VecX& w = p2s.weights();
  append_bytes(key, w.data(), sizeof(double) * static_cast<std::size_t>(w.size()));
  append_bytes(key, p2s.round_weight());
  append_bytes(key, p2s.rho_ball().center.data(), 3 * sizeof(double));
  append_bytes(key, p2s.rho_ball().radius);
  append_bytes(key, p2s.strict_params().eps);
  append_bytes(key, p2s.strict_params().sigma);
  append_bytes(key, p2s.phi().h());
  const int k = p2s.phi().k();
  append_bytes(key, &k, sizeof k);
  append_bytes(key, &samples, sizeof samples);
  append_bytes(key, &seed, sizeof seed);
  return key;
}

std::size_t report_bytes(const ValidationReport& r) { return r.message.size(); }
using VerdictCache = detail::ExactKeyCache<ValidationReport, report_bytes>;

VerdictCache& cache() {
  static VerdictCache c(kValidationCacheBytes);
  return c;
}

// ---------------------------------------------------------------------------------------------
// Candidate points.

// n roughly uniform unit directions (Fibonacci sphere).
std::vector<Vec3> sphere_directions(int n) {
  std::vector<Vec3> d;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / n, r = std::sqrt(1.0 - z * z);
    d.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  return d;
}

// Points of the shape's boundary where E_S's spike can sit: vertices, points along edges and
// face centres (polytopes, boxes), rims and caps (cylinders), and support points of many
// directions (every shape).
std::vector<Vec3> boundary_features(const Shape& shape) {
  std::vector<Vec3> f;
  for (const Vec3& d : sphere_directions(256)) f.push_back(support(shape, d));
  std::visit(
      Overloaded{
          [&](const Polytope& p) {
            f.insert(f.end(), p.vertices.begin(), p.vertices.end());
            std::vector<std::pair<int, int>> edges;
            for (const auto& t : p.faces) {
              f.emplace_back((p.vertices[t[0]] + p.vertices[t[1]] + p.vertices[t[2]]) / 3);
              for (int k = 0; k < 3; ++k)
                edges.emplace_back(std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3]));
            }
            std::sort(edges.begin(), edges.end());
            edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
            // Three points per edge; only the midpoint on large polytopes (hulls up to 1000
            // facets), whose edges are short.
            const std::vector<double> along =
                edges.size() <= 300 ? std::vector<double>{0.25, 0.5, 0.75} : std::vector<double>{0.5};
            for (const auto& [i, j] : edges)
              for (double t : along) f.emplace_back((1 - t) * p.vertices[i] + t * p.vertices[j]);
          },
          [&](const Box& b) {
            const Vec3 h = b.size / 2;
            for (int k = 0; k < 3; ++k) {
              const int i = (k + 1) % 3, j = (k + 2) % 3;
              for (double si : {-1.0, 1.0}) {
                Vec3 face = Vec3::Zero();
                face[k] = si * h[k];
                f.push_back(face);  // face centre
                for (double sj : {-1.0, 1.0})
                  for (double t : {-1.0, -0.5, 0.0, 0.5, 1.0}) {  // edges along axis k
                    Vec3 e;
                    e[k] = t * h[k];
                    e[i] = si * h[i];
                    e[j] = sj * h[j];
                    f.push_back(e);
                  }
              }
            }
          },
          [&](const Cylinder& c) {
            for (int a = 0; a < 64; ++a) {
              const double t = 2 * M_PI * a / 64;
              for (double z : {-0.5, -0.25, 0.0, 0.25, 0.5})
                f.emplace_back(c.radius * std::cos(t), c.radius * std::sin(t), z * c.height);
            }
            f.emplace_back(0, 0, c.height / 2);
            f.emplace_back(0, 0, -c.height / 2);
          },
          [&](const auto&) {}},
      shape);
  return f;
}

// Planes u·p = b bounding the shape (unit u): its rows, or for round shapes the caps and
// tangent planes around the axis. Far out along a plane, that term of e_S stays finite while the
// others grow, and the Hessian's limit there differs from the limits on either side.
std::vector<std::pair<Vec3, double>> bounding_planes(const Shape& shape) {
  std::vector<std::pair<Vec3, double>> planes;
  MatX3 A;
  VecX b;
  if (const auto* p = std::get_if<Polytope>(&shape)) A = p->A, b = p->b;
  if (const auto* box = std::get_if<Box>(&shape)) box_halfspaces(*box, A, b);
  for (Eigen::Index i = 0; i < A.rows(); ++i) planes.emplace_back(A.row(i).transpose(), b[i]);
  const auto round = [&](double radius, double half) {
    planes.emplace_back(Vec3::UnitZ(), half);
    planes.emplace_back(-Vec3::UnitZ(), half);
    for (int a = 0; a < 8; ++a) {
      const double t = 2 * M_PI * a / 8;
      planes.emplace_back(Vec3(std::cos(t), std::sin(t), 0), radius);
    }
  };
  if (const auto* c = std::get_if<Cylinder>(&shape)) round(c->radius, c->height / 2);
  if (const auto* c = std::get_if<Capsule>(&shape)) round(c->radius, c->height / 2 + c->radius);
  if (const auto* s = std::get_if<Sphere>(&shape)) round(s->radius, s->radius);
  return planes;
}

struct Candidate {
  double value;
  Vec3 p;
};

// The `count` best distinct candidates, best first (features repeat: a vertex is the support
// point of many directions).
std::vector<Candidate> best(std::vector<Candidate> c, std::size_t count) {
  const auto lexicographic = [](const Candidate& x, const Candidate& y) {
    return std::lexicographical_compare(x.p.data(), x.p.data() + 3, y.p.data(), y.p.data() + 3);
  };
  std::sort(c.begin(), c.end(), lexicographic);
  c.erase(std::unique(c.begin(), c.end(),
                      [](const Candidate& x, const Candidate& y) { return x.p == y.p; }),
          c.end());
  const auto by_value = [](const Candidate& x, const Candidate& y) { return x.value > y.value; };
  count = std::min(count, c.size());
  std::partial_sort(c.begin(), c.begin() + static_cast<std::ptrdiff_t>(count), c.end(), by_value);
  c.resize(count);
  return c;
}

// ---------------------------------------------------------------------------------------------
// The search.

class Search {
 public:
  explicit Search(const PointToSet& p2s)
      : p2s_(p2s), c_(p2s.rho_ball().center), max_distance_(1e6 * p2s.rho_ball().radius) {
    rep_.min_eigenvalue = INFINITY;
  }

  // λ_max(∂²E_S(p)) outside the set, −∞ inside. `full`: also the smallest eigenvalue (the
  // iterative solver: the closed form loses small eigenvalues).
  double evaluate(const Vec3& p, bool full = false) {
    const P2SValue v = p2s_.strict(p, 2);
    ++rep_.samples;
    if (p2s_.contains(p)) {
      rep_.max_inside_norm = std::max(rep_.max_inside_norm, v.hessian.norm());
      return -INFINITY;
    }
    double lmax;
    Eigen::SelfAdjointEigenSolver<Mat3> es;
    if (full) {
      es.compute(v.hessian, Eigen::EigenvaluesOnly);
      lmax = es.eigenvalues()[2];
      const double lmin = es.eigenvalues()[0];
      // Eigenvalues carry an absolute rounding error of ~eps ‖H‖: below that, negative is zero.
      if (lmin < rep_.min_eigenvalue) {
        rep_.min_eigenvalue = lmin;
        rep_.min_eigenvalue_tolerance = 64 * 2.2e-16 * std::max(std::abs(lmax), 1e-300);
      }
    } else {
      es.computeDirect(v.hessian, Eigen::EigenvaluesOnly);
      lmax = es.eigenvalues()[2];
    }
    if (!std::isfinite(lmax)) lmax = INFINITY;  // a non-finite Hessian fails Property 2 too
    if (lmax > best_.value || best_.p.hasNaN()) best_ = {lmax, p};
    return lmax;
  }

  // Compass search from p in (direction, distance) about the ρ centre: angular steps keep the
  // distance, so a point on the thin shell at ρ = 0 stays on it. The angular and radial steps are
  // separate (the shell is far thinner than it is wide), doubled after a success and halved
  // after a failure; the tangent frame turns by the golden angle every round and diagonal moves
  // are tried when the axes fail, so the search does not stall on a kink of λ_max (where the
  // two largest eigenvalues cross).
  void ascend(Vec3 p, double value, double angle_step, double radial_step) {
    ++rep_.ascents;
    double ta = angle_step, tr = radial_step;
    const double min_radial = 1e-12 * std::max(1.0, (p - c_).norm());
    const double golden = M_PI * (3.0 - std::sqrt(5.0));
    int evals = 0;
    const auto try_move = [&](double angle, const Vec3& t, double dr) {
      const Vec3 d = p - c_;
      const double r = d.norm(), r2 = r + dr;
      if (!(r2 > 0) || r2 > max_distance_) return false;
      const Vec3 q = c_ + r2 * (d / r + angle * t).normalized();
      const double fq = evaluate(q);
      ++evals;
      if (!(fq > value)) return false;
      p = q, value = fq;
      return true;
    };
    for (int round = 0; evals < kAscentEvaluations; ++round) {
      if (ta < 1e-12 && tr < min_radial) break;
      const Vec3 d = p - c_;
      if (!(d.norm() > 0)) break;
      const Vec3 w = d.normalized(), u1 = w.unitOrthogonal(), u2 = w.cross(u1);
      const double phi = golden * round;
      const Vec3 t1 = std::cos(phi) * u1 + std::sin(phi) * u2, t2 = w.cross(t1);
      const bool tangent = try_move(ta, t1, 0) || try_move(-ta, t1, 0) || try_move(ta, t2, 0) ||
                           try_move(-ta, t2, 0);
      const bool radial = try_move(0, t1, tr) || try_move(0, t1, -tr);
      ta = tangent ? std::min(2 * ta, 0.5) : 0.5 * ta;
      tr = radial ? std::min(2 * tr, (p - c_).norm()) : 0.5 * tr;
      if (!tangent && !radial)
        for (const Vec3& t : {t1, t2})
          if (try_move(ta, t, tr) || try_move(ta, t, -tr) || try_move(-ta, t, tr) ||
              try_move(-ta, t, -tr))
            break;
    }
    evaluate(p, true);  // the end point's smallest eigenvalue too
  }

  ValidationReport run(int samples, std::uint64_t seed);

 private:
  static constexpr int kAscentEvaluations = 800;
  // Which parameters lower ∂²E at p, from eq. 6's two regimes there. Where σe > ε|ρ|, E ≈ ερ +
  // σe + ε²ρ²/(2σe), whose Hessian has ε²∇ρ∇ρᵀ/(σe) (the ρ sphere, where e is small) and
  // ε²ρ²∇e∇eᵀ/(σe³): it grows with ε² and falls with σ and the weights (e and ∇e scale with
  // them); at the ρ sphere a larger ball moves it where e is larger. Where σe < ε|ρ| (near the
  // set), E ≈ ε(ρ + |ρ|) + σ²e²/(2ε|ρ|), with σ²∇e∇eᵀ/(ε|ρ|): the other way round.
  // First of all, σ∂²e_S itself (e large): below 1 only with weights W_i ≤ 1/m (Section III-B).
  std::string remedy(const Vec3& p, double eigenvalue) const {
    const P2SValue weak = p2s_.weak(p, 2);
    const double e = weak.value;
    const Ball& ball = p2s_.rho_ball();
    const double rho = 0.5 * ((p - ball.center).squaredNorm() - ball.radius * ball.radius);
    const StrictParams& sp = p2s_.strict_params();
    const double weak_part = sp.sigma * Eigen::SelfAdjointEigenSolver<Mat3>(weak.hessian, Eigen::EigenvaluesOnly).eigenvalues()[2];
    if (weak_part >= 1)
      return "there sigma times the Hessian of e_S alone has eigenvalue " + std::to_string(weak_part) +
             ": decrease the weights or sigma";
    if (sp.sigma * e > sp.eps * std::abs(rho)) {
      const bool at_sphere = std::abs(rho) < 0.1 * ball.radius * ball.radius;
      std::string advice = std::string("there it grows like eps^2/sigma: decrease eps (halving it quarters that growth), or increase the weights or sigma") +
                           (at_sphere ? ", or enlarge the rho ball (the point is near its sphere)" : "");
      // Φ(s) ≈ s³/(6h) for s << h, so over a shape far smaller than h, e_S and with it this
      // growth scale like 1/h.
      const double h = p2s_.phi().h(), size = bounding_ball(p2s_.shape()).radius;
      if (size < 0.1 * h)
        advice += "; the shape (bounding radius " + std::to_string(size) + ") is far smaller than h = " +
                  std::to_string(h) + ", and this growth falls in proportion to h: h below about " +
                  std::to_string(h / eigenvalue) + " (or leave such a small shape out)";
      return advice;
    }
    return "there it grows like sigma^2/eps: decrease sigma or the weights, increase eps, or enlarge the rho ball";
  }

  const PointToSet& p2s_;
  const Vec3 c_;  // ρ centre, shape frame
  // The far field's limit is reached to O(1/distance); beyond this the ascent stops (and A, B
  // ~ distance² keep far from overflow).
  const double max_distance_;
  ValidationReport rep_;
  Candidate best_{-INFINITY, Vec3::Constant(NAN)};
};

ValidationReport Search::run(int samples, std::uint64_t seed) {
  const Shape& shape = p2s_.shape();
  const double R = p2s_.rho_ball().radius;
  const std::vector<Vec3> features = boundary_features(shape);

  // 1. The sphere ρ = 0 above every boundary feature (the radial projection is the sphere's
  //    closest point to it, where e_S is smallest on the sphere).
  //    Halfway between the feature and the sphere as well (a maximum can sit inside the ball).
  std::vector<Candidate> shell, between;
  for (const Vec3& x : features) {
    const Vec3 d = x - c_;
    if (!(d.norm() > 0)) continue;
    const Vec3 p = c_ + R * d.normalized(), q = 0.5 * (x + p);
    shell.push_back({evaluate(p), p});
    between.push_back({evaluate(q), q});
  }
  for (const Candidate& s : best(shell, 48)) ascend(s.p, s.value, 0.05, 0.02 * R);
  for (const Candidate& s : best(between, 16)) ascend(s.p, s.value, 0.05, 0.1 * R);

  // 2. The far field, where ∂²E_S tends to a limit per direction.
  std::vector<Vec3> dirs = sphere_directions(128);
  if (const auto* poly = std::get_if<Polytope>(&shape))
    for (int i = 0; i < poly->rows(); ++i) dirs.emplace_back(poly->A.row(i).transpose());
  std::vector<Candidate> far;
  for (const Vec3& w : dirs)
    for (double scale : {2.0, 8.0, 64.0}) {
      const Vec3 p = c_ + scale * R * w;
      far.push_back({evaluate(p), p});
    }
  for (const Candidate& s : best(far, 8)) ascend(s.p, s.value, 0.1, 0.5 * (s.p - c_).norm());
  // Far out along each bounding plane (and along the intersection of two of them), at a few
  // violations s of that plane's term: the supremum can sit there, approached only at infinity.
  const auto planes = bounding_planes(shape);
  std::vector<Candidate> tangent;
  const double r_far = 1e4 * R;
  const auto add_tangent = [&](const Vec3& w, const std::vector<std::pair<Vec3, double>>& on) {
    for (double s : {0.0, 1.0, 10.0, 100.0}) {
      Vec3 p = c_ + r_far * w;
      for (const auto& [u, b] : on) p += (b + s - u.dot(p)) * u;
      tangent.push_back({evaluate(p), p});
    }
  };
  // 16 directions per plane, fewer on large polytopes (at least 4).
  const int per_plane = std::clamp(2048 / static_cast<int>(planes.size()), 4, 16);
  for (const auto& [u, b] : planes) {
    const Vec3 t1 = u.unitOrthogonal(), t2 = u.cross(t1);
    for (int a = 0; a < per_plane; ++a) {
      const double angle = 2 * M_PI * a / per_plane;
      add_tangent(std::cos(angle) * t1 + std::sin(angle) * t2, {{u, b}});
    }
  }
  if (planes.size() <= 64)
    for (std::size_t i = 0; i < planes.size(); ++i)
      for (std::size_t j = i + 1; j < planes.size(); ++j) {
        const Vec3 w = planes[i].first.cross(planes[j].first);
        if (!(w.norm() > 1e-6)) continue;
        for (double sign : {1.0, -1.0}) add_tangent(sign * w.normalized(), {planes[i], planes[j]});
      }
  for (const Candidate& s : best(tangent, 8)) ascend(s.p, s.value, 1e-3, 0.5 * (s.p - c_).norm());

  // 3. Random points near the boundary (offsets from 1e-4 to 10 radii) and in a large ball,
  //    which also check ∂²E_S = 0 inside and > 0 outside.
  const Ball ball = bounding_ball(shape);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const auto random_dir = [&] {
    Vec3 d(normal(rng), normal(rng), normal(rng));
    return Vec3(d / std::max(d.norm(), 1e-300));
  };
  std::vector<Candidate> random;
  for (int i = 0; i < samples; ++i) {
    Vec3 p;
    const double scale = ball.radius * std::pow(10.0, -4.0 + 5.0 * uniform(rng));
    if (i % 2 == 0)
      p = support(shape, random_dir()) + scale * random_dir();
    else
      p = ball.center + 4.0 * ball.radius * std::cbrt(uniform(rng)) * random_dir();
    const double l = evaluate(p, true);
    if (std::isfinite(l)) random.push_back({l, p});
  }
  for (const Candidate& s : best(random, 8)) ascend(s.p, s.value, 0.05, 0.05 * R);

  // Report the worst point with the iterative solver (what a direct evaluation gives).
  if (!best_.p.hasNaN()) {
    const Vec3 worst = best_.p;
    const P2SValue v = p2s_.strict(worst, 2);
    Eigen::SelfAdjointEigenSolver<Mat3> es(v.hessian, Eigen::EigenvaluesOnly);
    rep_.max_eigenvalue = v.hessian.allFinite() ? es.eigenvalues()[2] : INFINITY;
    rep_.worst_point = worst;
  }
  if (!std::isfinite(rep_.min_eigenvalue)) rep_.min_eigenvalue = 0;
  std::ostringstream msg;
  if (!(rep_.max_eigenvalue < 1.0)) {
    msg << "Property 2 fails: the Hessian of E_S has eigenvalue " << rep_.max_eigenvalue
        << " >= 1 at (" << rep_.worst_point.transpose() << ") in the shape frame; " << remedy(rep_.worst_point, rep_.max_eigenvalue);
  } else if (rep_.min_eigenvalue < -rep_.min_eigenvalue_tolerance) {
    msg << "Property 2 fails: E_S is not convex (eigenvalue " << rep_.min_eigenvalue << ")";
  } else if (rep_.max_inside_norm > 0) {
    msg << "Property 2 fails: the Hessian of E_S is not zero inside the set";
  } else {
    rep_.ok = true;
    msg << "Property 2 holds: largest Hessian eigenvalue found " << rep_.max_eigenvalue
        << " (" << rep_.ascents << " local maximisations from the sphere rho = 0, the far field "
        << "and random points; " << rep_.samples << " evaluations)";
  }
  rep_.message = msg.str();
  return rep_;
}

}  // namespace

ValidationReport validate_p2s(const PointToSet& original, int samples, std::uint64_t seed) {
  const std::string key = cache_key(original, samples, seed);
  ValidationReport rep;
  if (cache().find(key, rep)) {
    rep.cached = true;
    return rep;
  }
  PointToSet p2s = original;
  p2s.set_pose(Pose{});
  rep = Search(p2s).run(samples, seed);
  cache().insert(key, rep);
  return rep;
}

CacheStats validation_cache_stats() { return cache().stats(); }
void clear_validation_cache() { cache().clear(); }
void set_validation_cache_capacity(std::size_t bytes) { cache().set_capacity(bytes); }

}  // namespace distlab
