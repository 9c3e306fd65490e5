// cbf_rows, the CBF rows C u ≥ d for a caller's own QP (eq. 7 and the joint limits), from
// DistanceModel results: the rows of franka-corridor.md's controller from its numbers (η = 0.5,
// the margins, the joint limits in degrees), equal to the built-in controller's rows for the
// same state, and the rows every step of a rollout solved (the step's u is the QP's optimum for
// them: feasible, and stationary with its active rows' multipliers).
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "mesh_robot.hpp"
#include "robot_test_util.hpp"

#include "distlab/cbf/controller.hpp"
#include "distlab/cbf/rows.hpp"
#include "distlab/robot/distances.hpp"

namespace distlab::robot {
namespace {

using cbf::CbfController;
using cbf::RowParams;
using cbf::Scenario;

Scenario narrow() { return cbf::corridor_narrow_scenario(test::panda()); }

PairSelection selection(const Scenario& sc) {
  PairSelection s;
  s.self = sc.self_collision;
  return s;
}

// The same configurations through the controller (its rows continue its tracks) and through a
// model with the scenario's obstacles, parameters and pairs (a workspace of its own, tracked in
// the same order): the same rows.
TEST(RobotCbfRows, EqualTheControllersRows) {
  const Scenario sc = narrow();
  std::mt19937_64 rng(9);
  std::vector<VecQ> qs = {sc.q0};
  for (int i = 0; i < 5; ++i) qs.push_back(test::random_q(rng, *sc.robot));
  for (int i = 0; i < 5; ++i) qs.emplace_back(sc.q0 + 0.01 * i * VecQ::Ones(7));  // a short path: tracked
  for (const Metric metric : {Metric::gap, Metric::euclidean}) {
    CbfController controller(sc, metric);
    const DistanceModel model(sc.robot, sc.obstacles, metric, sc.gap, selection(sc));
    ASSERT_EQ(model.pairs().size(), controller.pairs().size());
    DistanceModel::Workspace w = model.workspace();
    std::vector<PairDistance> out(model.pairs().size());
    GradQ grad;
    const RowParams params{sc.margins(metric), sc.eta, sc.eta_joint};
    for (const VecQ& q : qs) {
      Eigen::MatrixXd C, C2;
      Eigen::VectorXd d, d2;
      controller.rows(q, C, d);
      model.evaluate(q, w, true, out, grad);
      cbf::cbf_rows(*sc.robot, model.pairs(), q, out, grad, params, C2, d2);
      ASSERT_EQ(C.rows(), C2.rows());
      ASSERT_EQ(C.cols(), 7);
      EXPECT_LE((C - C2).cwiseAbs().maxCoeff(), 1e-12 * C2.cwiseAbs().maxCoeff()) << to_string(metric);
      EXPECT_LE((d - d2).cwiseAbs().maxCoeff(), 1e-12 * d2.cwiseAbs().maxCoeff()) << to_string(metric);
    }
  }
}

// franka-corridor.md, "Controller": ∇_q D · u ≥ −η (D − δ) per pair (δ_obs 0.002 / δ_auto 0.0001
// with GAP, 0.03 / 0.01 Euclidean), then u ≥ −η (q − q_min) and −u ≥ −η (q_max − q), η = 0.5,
// the limits the table's degrees.
TEST(RobotCbfRows, TheControllersRowsFromItsNumbers) {
  const Scenario sc = narrow();
  const double lo[7] = {-166, -101, -166, -176, -166, -1, -166}, hi[7] = {166, 101, 166, -4, 166, 215, 166};
  std::mt19937_64 rng(10);
  for (const Metric metric : {Metric::gap, Metric::euclidean}) {
    const double delta_obs = metric == Metric::gap ? 0.002 : 0.03, delta_self = metric == Metric::gap ? 0.0001 : 0.01;
    const DistanceModel model(sc.robot, sc.obstacles, metric, sc.gap, selection(sc));
    const int np = static_cast<int>(model.pairs().size());
    ASSERT_EQ(np, 27 + 25);
    ASSERT_EQ(cbf::joint_limit_rows(*sc.robot), 14);
    for (int trial = 0; trial < 3; ++trial) {
      const VecQ q = test::random_q(rng, *sc.robot);
      const VecQ qv = q;
      const DistanceBatch b = distances(model, std::span<const double>(qv.data(), 7), 1);
      DistanceModel::Workspace w = model.workspace();
      std::vector<PairDistance> out(np);
      GradQ grad;
      model.evaluate(q, w, false, out, grad);
      Eigen::MatrixXd C;
      Eigen::VectorXd d;
      cbf::cbf_rows(*sc.robot, model.pairs(), q, out, grad, RowParams{sc.margins(metric), sc.eta, sc.eta_joint}, C, d);
      ASSERT_EQ(C.rows(), np + 14);
      for (int p = 0; p < np; ++p) {
        const double delta = model.pairs()[p].self ? delta_self : delta_obs;
        EXPECT_DOUBLE_EQ(d[p], -0.5 * (b.distance[p] - delta)) << model.pairs()[p].name;
        for (int j = 0; j < 7; ++j) EXPECT_NEAR(C(p, j), b.jacobian[static_cast<std::size_t>(p) * 7 + j], 1e-15 * (1 + std::abs(C(p, j))));
      }
      for (int i = 0; i < 7; ++i) {
        const double q_min = lo[i] * std::numbers::pi / 180, q_max = hi[i] * std::numbers::pi / 180;
        const Eigen::RowVectorXd e = Eigen::RowVectorXd::Unit(7, i);
        EXPECT_EQ(C.row(np + i), e);
        EXPECT_NEAR(d[np + i], -0.5 * (q[i] - q_min), 1e-15);
        EXPECT_EQ(C.row(np + 7 + i), -e);
        EXPECT_NEAR(d[np + 7 + i], -0.5 * (q_max - q[i]), 1e-15);
      }
    }
  }
}

// A robot with a continuous joint (mesh_robot.hpp: j3) has no limit rows for it.
TEST(RobotCbfRows, ContinuousJointsHaveNoLimitRows) {
  test::TempDir dir;
  const test::MeshRobot spec = test::write_mesh_robot(dir);
  const auto robot = Robot::from_file(spec.urdf_path, "robot", spec.options);
  ASSERT_EQ(cbf::joint_limit_rows(*robot), 6);
  const std::vector<Obstacle> obstacles = {{"ball", Sphere{0.05}, {Vec3(0.45, -0.1, 0.55), Quat::Identity()}}};
  const DistanceModel model(robot, obstacles, Metric::gap, GapParams{}, PairSelection{});
  VecQ q(4);
  q << 0.3, -0.2, 0.1, 5.0;
  DistanceModel::Workspace w = model.workspace();
  std::vector<PairDistance> out(model.pairs().size());
  GradQ grad;
  model.evaluate(q, w, false, out, grad);
  Eigen::MatrixXd C;
  Eigen::VectorXd d;
  RowParams params;
  params.eta_joint = 2;
  cbf::cbf_rows(*robot, model.pairs(), q, out, grad, params, C, d);
  const int np = static_cast<int>(model.pairs().size());
  ASSERT_EQ(C.rows(), np + 6);
  // Lower limits of j1, j6, j2, then their upper limits.
  const double q_min[3] = {-2, -1.5, -0.1}, q_max[3] = {2, 1.5, 0.3};
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(C.row(np + i), Eigen::RowVectorXd::Unit(4, i));
    EXPECT_NEAR(d[np + i], -2 * (q[i] - q_min[i]), 1e-15);
    EXPECT_EQ(C.row(np + 3 + i), -Eigen::RowVectorXd::Unit(4, i));
    EXPECT_NEAR(d[np + 3 + i], -2 * (q_max[i] - q[i]), 1e-15);
  }
  EXPECT_EQ(C.col(3).tail(6), Eigen::VectorXd::Zero(6));
}

// A rollout: at each step, the rows cbf_rows builds from the batch along the same path (tracked,
// one thread: the controller's sequence of solves) are the rows the step's QP solved: its u
// satisfies them, its active rows hold with equality, and H u + f = C_Aᵀ λ_A with λ ≥ 0 for
// H = J_rᵀJ_r + λI, f = J_rᵀ K r of the task function.
TEST(RobotCbfRows, ARolloutStepSolvesTheseRows) {
  const Scenario sc = narrow();
  for (const Metric metric : {Metric::gap, Metric::euclidean}) {
    CbfController controller(sc, metric);
    const int steps = 150;
    std::vector<VecQ> qs = {sc.q0};
    std::vector<cbf::StepOutput> outs;
    for (int k = 0; k < steps; ++k) {
      outs.push_back(controller.step(qs.back(), false));
      const VecQ next = qs.back() + sc.dt * outs.back().u;
      qs.push_back(next);
    }
    std::vector<double> flat;
    for (int k = 0; k < steps; ++k) flat.insert(flat.end(), qs[k].data(), qs[k].data() + 7);
    const DistanceModel model(sc.robot, sc.obstacles, metric, sc.gap, selection(sc));
    BatchOptions one;
    one.threads = 1;
    const DistanceBatch b = distances(model, flat, steps, one);
    const int np = b.pairs;
    int active_pair_rows = 0;
    for (int k = 0; k < steps; ++k) {
      const cbf::StepOutput& s = outs[k];
      ASSERT_FALSE(s.relaxed) << k;
      ASSERT_FALSE(s.clipped) << k;
      std::vector<PairDistance> pd(np);
      GradQ grad(np, 7);
      for (int p = 0; p < np; ++p) {
        const std::size_t cell = static_cast<std::size_t>(k) * np + p;
        pd[p].distance = b.distance[cell];
        for (int j = 0; j < 7; ++j) grad(p, j) = b.jacobian[cell * 7 + j];
        ASSERT_EQ(s.pairs[p].distance, b.distance[cell]) << k << " " << model.pairs()[p].name;
      }
      Eigen::MatrixXd C;
      Eigen::VectorXd d;
      cbf::cbf_rows(*sc.robot, model.pairs(), qs[k], pd, grad, RowParams{sc.margins(metric), sc.eta, sc.eta_joint}, C, d);
      const Eigen::VectorXd slack = C * s.u - d;
      EXPECT_GE(slack.minCoeff(), -1e-9) << k;
      const cbf::Task task = cbf::task_function(sc.robot->forward(qs[k]), *sc.robot, sc.target);
      const Eigen::MatrixXd H = task.J.transpose() * task.J + sc.damping * Eigen::MatrixXd::Identity(7, 7);
      Eigen::VectorXd residual = H * s.u + task.J.transpose() * (sc.task_gain * task.r);
      for (std::size_t a = 0; a < s.active.size(); ++a) {
        const int row = s.active[a];
        EXPECT_NEAR(slack[row], 0, 1e-9) << k << " row " << row;
        EXPECT_GE(s.multiplier[a], 0) << k << " row " << row;
        residual -= s.multiplier[a] * C.row(row).transpose();
        active_pair_rows += row < np;
      }
      EXPECT_LE(residual.cwiseAbs().maxCoeff(), 1e-9 * (1 + (H * s.u).cwiseAbs().maxCoeff())) << k;
    }
    EXPECT_GT(active_pair_rows, 0) << to_string(metric) << ": no distance row was ever active";
  }
}

}  // namespace
}  // namespace distlab::robot
