// gap.mode as_published against a cold-start iteration computed here, independently, from the
// paper's formulas and the published construction (franka-corridor.md):
//   Φ'' = (1 − (1+s)^(−1/h))^(k−1), Φ(0) = Φ'(0) = 0 (eq. 4), k = 2, h = 0.1:
//     Φ(s) = s²/2 − s/9 + (1 − (1+s)^−8)/72,  Φ'(s) = s − (1 − (1+s)^−9)/9;
//   box e = Σ_i Φ(u_i·p − b_i) (weight 1), cylinder e = Φ(‖p_xy‖ − r) + Φ(z − h/2) + Φ(−z − h/2);
//   E = ερ + sqrt(ε²ρ² + σ²e²), ρ = ½(‖p − c‖² − R²), R² = 1.2 × half diagonal² (eq. 6);
//   Π(p) = p − ∇E(p); a ← Π_A(Π_B(a)) from B's centre (eq. 2), stop at the first step below tol;
//   D = sqrt(max(2 E_B(a) + 2 E_A(b) − ‖a − b‖², 0)), b = Π_B(a) (eq. 3).
#include <cmath>
#include <functional>

#include <gtest/gtest.h>

#include "panda.hpp"

#include "distlab/cbf/controller.hpp"

namespace distlab::cbf {
namespace {

constexpr double kEps = 0.01;
const double kSigma = std::sqrt(1 - 2 * kEps);

double phi(double s) { return s > 0 ? s * s / 2 - s / 9 + (1 - std::pow(1 + s, -8)) / 72 : 0; }
double dphi(double s) { return s > 0 ? s - (1 - std::pow(1 + s, -9)) / 9 : 0; }

struct Local {  // e and ∇e in the shape's frame
  double e;
  Vec3 g;
};

Local box_e(const Vec3& p, const Vec3& half) {
  Local l{0, Vec3::Zero()};
  for (int i = 0; i < 3; ++i)
    for (double sgn : {1.0, -1.0}) {
      const double s = sgn * p[i] - half[i];
      l.e += phi(s);
      l.g[i] += sgn * dphi(s);
    }
  return l;
}

Local cylinder_e(const Vec3& p, double r, double h) {
  const double rho_xy = std::hypot(p.x(), p.y());
  Local l{phi(rho_xy - r) + phi(p.z() - h / 2) + phi(-p.z() - h / 2), Vec3::Zero()};
  if (rho_xy > 0) l.g.head<2>() = dphi(rho_xy - r) * p.head<2>() / rho_xy;
  l.g.z() = dphi(p.z() - h / 2) - dphi(-p.z() - h / 2);
  return l;
}

struct Body {
  Pose pose;
  double R2;  // ρ ball radius², centred at the shape's origin
  std::function<Local(const Vec3&)> weak;
  // E and ∇E at a world point.
  std::pair<double, Vec3> E(const Vec3& x) const {
    const Mat3 R = pose.R();
    const Vec3 p = R.transpose() * (x - pose.position);
    const Local l = weak(p);
    const double rho = 0.5 * (p.squaredNorm() - R2);
    const double v = std::sqrt(kEps * kEps * rho * rho + kSigma * kSigma * l.e * l.e);
    const Vec3 g = kEps * p + (kEps * kEps * rho * p + kSigma * kSigma * l.e * l.g) / v;
    return {kEps * rho + v, R * g};
  }
  Vec3 project(const Vec3& x) const { return x - E(x).second; }
};

TEST(AsPublished, MatchesAHandComputedColdStartIteration) {
  // A: the link-5 cylinder (r 0.06, h 0.22), tilted; B: wall 1 of the real corridor.
  Pose pa;
  pa.position = Vec3(0.50, 0.05, 0.62);
  pa.rotation = Quat(Eigen::AngleAxisd(0.3, Vec3::UnitX()));
  Pose pb;
  pb.position = Vec3(0.52, 0.19, 0.48);
  const Cylinder cyl{0.06, 0.22};
  const Box wall{Vec3(0.32, 0.08, 0.92)};
  const Body A{pa, 1.2 * (2 * 0.06 * 0.06 + 0.11 * 0.11),
               [&](const Vec3& p) { return cylinder_e(p, cyl.radius, cyl.height); }};
  const Body B{pb, 1.2 * (wall.size / 2).squaredNorm(), [&](const Vec3& p) { return box_e(p, wall.size / 2); }};

  for (const auto& [tol, max_iter] : {std::pair{5e-4, 20}, std::pair{2e-4, 300}, std::pair{1e-12, 3}}) {
    SCOPED_TRACE(testing::Message() << "tol " << tol << ", max_iter " << max_iter);
    Vec3 a = pb.position;  // cold start at B's centre
    int it = 0;
    bool stopped = false;
    while (it < max_iter) {
      const Vec3 next = A.project(B.project(a));
      ++it;
      const double step = (next - a).norm();
      a = next;
      if (step < tol) {
        stopped = true;
        break;
      }
    }
    EXPECT_GE(it, 2);  // a real iteration, not a first step below tol
    const Vec3 b = B.project(a);
    const double D = std::sqrt(std::max(2 * B.E(a).first + 2 * A.E(b).first - (a - b).squaredNorm(), 0.0));

    GapParams params;
    params.tol = tol;
    params.max_iter = max_iter;
    const GapBody ga(cyl, pa, params, published_options(cyl), "a");
    const GapBody gb(wall, pb, params, published_options(wall), "b");
    const GapResult g = published_distance(ga, gb, params);
    EXPECT_EQ(g.iterations, it);
    EXPECT_EQ(g.converged, stopped);
    EXPECT_NEAR(g.distance, D, 1e-12);
    EXPECT_LT((g.witness_a - a).norm(), 1e-12);
    EXPECT_LT((g.witness_b - b).norm(), 1e-12);
    EXPECT_GT(D, 0.0);
  }
}

// The controller in gap.mode as_published computes every pair with published_distance on the
// published construction, and records beside it the converged D of the same functions.
TEST(AsPublished, ControllerRowsAreThePublishedDistances) {
  Scenario sc = test::narrow();
  sc.self_collision = false;
  sc.gap_mode = GapMode::as_published;
  sc.gap.tol = 5e-4;
  sc.gap.max_iter = 20;
  CbfController c(sc, Metric::gap);
  std::vector<PairSample> samples;
  GradQ grad;
  c.distances(sc.q0, samples, grad);
  const Robot& robot = c.robot();
  const Kinematics k = robot.forward(sc.q0);
  GapParams exact = sc.gap;
  exact.solver = GapSolver::newton;
  exact.tol = 1e-10;
  exact.max_iter = 0;
  ASSERT_EQ(samples.size(), c.pairs().size());
  for (std::size_t p = 0; p < samples.size(); ++p) {
    const PairInfo& pair = c.pairs()[p];
    const LinkPrimitive& prim = robot.primitives()[pair.a];
    const Obstacle& o = sc.obstacles[pair.b];
    const GapBody a(prim.shape, robot.primitive_pose(k, pair.a), sc.gap, published_options(prim.shape), "a");
    const GapBody b(o.shape, o.pose, sc.gap, published_options(o.shape), "b");
    EXPECT_EQ(samples[p].distance, published_distance(a, b, sc.gap).distance) << pair.name;
    EXPECT_NEAR(samples[p].converged_distance, gap_distance(a, b, exact).distance, 1e-9) << pair.name;
  }
}

}  // namespace
}  // namespace distlab::cbf
