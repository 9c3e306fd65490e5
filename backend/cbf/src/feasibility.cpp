#include "distlab/cbf/feasibility.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "distlab/cbf/rollout.hpp"
#include "distlab/geometry/error.hpp"

namespace distlab::cbf {
namespace {

// 6-D pose error: position, then the rotation vector of R·R_dᵀ (world frame).
Vec6 pose_error(const Kinematics& k, const Pose& target) {
  Vec6 e;
  e.head<3>() = k.ee.position - target.position;
  const Eigen::AngleAxisd aa(k.ee_R * target.R().transpose());
  e.tail<3>() = aa.angle() * aa.axis();
  return e;
}

// The first min(dof, 6) joints for the target, the others fixed, from `q` (damped Gauss–Newton,
// clamped to the limits). Returns false if it does not reach the pose within the limits.
bool solve_ik(const Robot& robot, const Pose& target, VecQ& q, double tol) {
  const int n = std::min(robot.dof(), 6);
  for (int it = 0; it < 60; ++it) {
    const Kinematics k = robot.forward(q);
    const Vec6 e = pose_error(k, target);
    if (e.norm() < tol) return true;
    const Eigen::MatrixXd J = robot.ee_jacobian(k).leftCols(n);
    const double lambda = e.norm() > 1e-3 ? 1e-4 : 0;  // damping only far from the solution
    const Eigen::VectorXd dq =
        (J.transpose() * J + lambda * Eigen::MatrixXd::Identity(n, n)).ldlt().solve(J.transpose() * e);
    if (!dq.allFinite()) return false;
    q.head(n) -= dq;
    for (int i = 0; i < n; ++i) {
      if (!(q[i] >= robot.q_min()[i] - 0.5 && q[i] <= robot.q_max()[i] + 0.5)) return false;
      q[i] = std::clamp(q[i], robot.q_min()[i], robot.q_max()[i]);
    }
  }
  return pose_error(robot.forward(q), target).norm() < tol;
}

struct Candidate {
  VecQ q;
  double clearance;
  int pair;
};

}  // namespace

Feasibility target_feasibility(const Scenario& scenario, const FeasibilityOptions& options) {
  Scenario sc = scenario;
  sc.gap_mode = GapMode::exact;
  CbfController euclid(sc, Metric::euclidean);
  const Robot& robot = euclid.robot();
  const int dof = robot.dof();
  // The scanned joint: the last one of a redundant arm (dof > 6); none for dof <= 6.
  const int free = dof > 6 ? dof - 1 : -1;
  const auto& pairs = euclid.pairs();
  std::vector<PairSample> samples;
  GradQ grad;
  auto obstacle_clearance = [&](const VecQ& q, int& arg) {
    euclid.distances(q, samples, grad);
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t p = 0; p < pairs.size(); ++p)
      if (!pairs[p].self && samples[p].clearance < best) {
        best = samples[p].clearance;
        arg = static_cast<int>(p);
      }
    return best;
  };

  Feasibility f;
  try {
    require_safe_start(sc, sc.q0);
  } catch (const InvalidInput& e) {
    f.start_problem = e.what();
  }
  Candidate best{VecQ::Zero(dof), -std::numeric_limits<double>::infinity(), -1};
  // Seeds: q0 and a fixed spread over joints 1–6 (elbow and wrist branches), plus continuation
  // from the previous grid point's solutions.
  std::vector<VecQ> seeds;
  seeds.push_back(sc.q0);
  for (int s = 1; s < options.seeds; ++s) {
    VecQ q(dof);
    for (int i = 0; i < dof; ++i) {
      const double t = std::fmod(0.6180339887498949 * (s * (i + 3)), 1.0);  // low-discrepancy
      q[i] = robot.q_min()[i] + (0.1 + 0.8 * t) * (robot.q_max()[i] - robot.q_min()[i]);
    }
    seeds.push_back(q);
  }
  std::vector<VecQ> previous;
  auto try_q7 = [&](double q7, std::vector<VecQ>* found) {
    std::vector<VecQ> starts = seeds;
    starts.insert(starts.end(), previous.begin(), previous.end());
    for (VecQ q : starts) {
      if (free >= 0) q[free] = q7;
      if (!solve_ik(robot, sc.target, q, options.pose_tol)) continue;
      ++f.configurations;
      int arg = -1;
      const double c = obstacle_clearance(q, arg);
      if (c > best.clearance) best = {q, c, arg};
      if (found) found->push_back(q);
    }
  };
  const double lo = free >= 0 ? robot.q_min()[free] : 0, hi = free >= 0 ? robot.q_max()[free] : 0;
  const int n = free >= 0 ? std::max(1, static_cast<int>(std::ceil((hi - lo) / options.q7_step))) : 0;
  for (int s = 0; s <= n; ++s) {
    std::vector<VecQ> found;
    try_q7(lo + (hi - lo) * s / n, &found);
    previous = std::move(found);
    if (previous.size() > 4) previous.resize(4);
  }
  if (best.pair >= 0 && free >= 0) {
    // Refine in q7 around the best grid point (golden-section-like shrinking bracket).
    double step = options.q7_step;
    for (int r = 0; r < 12; ++r) {
      step /= 2;
      const double centre = best.q[free];
      previous = {best.q};
      for (double q7 : {centre - step, centre + step})
        if (q7 >= lo && q7 <= hi) try_q7(q7, nullptr);
    }
  }
  if (best.pair < 0) return f;
  f.reachable = true;
  f.q = best.q;
  f.clearance = best.clearance;
  f.limiting_pair = pairs[best.pair].name;
  euclid.distances(best.q, samples, grad);
  f.self_clearance = std::numeric_limits<double>::infinity();
  for (std::size_t p = 0; p < pairs.size(); ++p)
    if (pairs[p].self) f.self_clearance = std::min(f.self_clearance, samples[p].clearance);
  CbfController gap(sc, Metric::gap);
  gap.distances(best.q, samples, grad);
  f.gap_distance = std::numeric_limits<double>::infinity();
  for (std::size_t p = 0; p < pairs.size(); ++p)
    if (!pairs[p].self && samples[p].distance < f.gap_distance) {
      f.gap_distance = samples[p].distance;
      f.gap_limiting_pair = pairs[p].name;
    }
  f.euclidean_feasible = f.clearance >= sc.euclidean_margins.obstacle;
  f.gap_feasible = f.gap_distance >= sc.gap_margins.obstacle;
  return f;
}

}  // namespace distlab::cbf
