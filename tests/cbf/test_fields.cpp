// Kelvin fields as CBF rows (cbf/fields.hpp): the chain rule of ∇_q h against finite differences
// of h(x(q)), the smoothed gradient against the closed form, control points, and the start check.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "../kelvin/sphere_fixture.hpp"
#include "distlab/cbf/rollout.hpp"
#include "distlab/geometry/error.hpp"

namespace distlab::cbf {
namespace {

using kelvin::testing::Sphere;

const std::string kAssets = std::string(DISTLAB_SOURCE_DIR) + "/assets";

std::shared_ptr<const Robot> hand_robot() { return Robot::load(kAssets + "/robots/panda_hand.urdf"); }

// A sphere of radius 0.1 around (0.5, 0.3, 0.2) in the world, with σ constant 0.2: its object
// frame is rotated and shifted, so a gradient that is not rotated back to the world is wrong.
struct SphereScene {
  Sphere sphere{0.1, Vec3(0.01, -0.02, 0.03), 0.2};
  Pose pose;
  std::shared_ptr<kelvin::Field> field;
  SphereScene() {
    pose.position = Vec3(0.5, 0.3, 0.2) - Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()) * sphere.centre;
    pose.rotation = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
    kelvin::PrepareOptions options;
    options.lx = 0.02;
    options.centre = sphere.centre + Vec3(0.012, -0.007, 0.005);
    field = std::make_shared<kelvin::Field>(kelvin::Field::prepare(kelvin::testing::sphere_mesh(sphere), options));
    field->set_sigma(kelvin::testing::constant_sigma(sphere.sigma));
  }
  SceneField scene_field(double margin = 0) const {
    SceneField f;
    f.name = "sphere";
    f.field = field;
    f.sigma = kelvin::testing::constant_sigma(sphere.sigma);
    f.pose = pose;
    f.margin = margin;
    return f;
  }
};

const SphereScene& scene() {
  static const SphereScene s;
  return s;
}

// Control points on several links (arm and fingers), each moved by different joints.
std::vector<ControlPoint> points(const Robot& robot) {
  std::vector<ControlPoint> out;
  for (const char* link : {"panda_link4", "panda_link6", "panda_hand", "panda_leftfinger", "panda_rightfinger"}) {
    auto s = sample_control_points(robot, link, "", 3, "control_points");
    out.insert(out.end(), s.begin(), s.end());
  }
  return out;
}

// Configurations that keep every point outside the sphere (rejection sampling, fixed seed).
std::vector<VecQ> configurations(const Robot& robot, FieldBarrier& barrier, int n) {
  std::mt19937 rng(7);
  std::vector<VecQ> out;
  std::vector<FieldPointSample> s;
  Eigen::MatrixXd g;
  while (static_cast<int>(out.size()) < n) {
    VecQ q(robot.dof());
    for (int i = 0; i < robot.dof(); ++i)
      q[i] = std::uniform_real_distribution<double>(robot.q_min()[i], robot.q_max()[i])(rng);
    barrier.evaluate(robot, robot.forward(q), s, g);
    bool ok = true;
    for (const auto& x : s) ok = ok && x.status == kelvin::Status::ok && x.h < 3;
    if (ok) out.push_back(q);
  }
  return out;
}

TEST(FieldRows, ChainRuleMatchesFiniteDifferencesOfH) {
  // The row with the derivative of the interpolated h itself (Gradient::cell) is the exact
  // derivative of q ↦ h(x(q)) inside a cell: central differences of 1e-7 rad stay in the cell.
  const auto robot = hand_robot();
  FieldBarrier barrier({scene().scene_field()}, points(*robot));
  std::vector<FieldPointSample> s, sp, sm;
  Eigen::MatrixXd g, gp, gm;
  int checked = 0;
  double worst = 0, worst_unrotated = 1e300;
  for (const VecQ& q : configurations(*robot, barrier, 20)) {
    barrier.evaluate(*robot, robot->forward(q), s, g, kelvin::Gradient::cell);
    const double eps = 1e-7;
    Eigen::MatrixXd fd(barrier.rows(), robot->dof());
    for (int i = 0; i < robot->dof(); ++i) {
      VecQ a = q, b = q;
      a[i] += eps;
      b[i] -= eps;
      barrier.evaluate(*robot, robot->forward(a), sp, gp, kelvin::Gradient::cell);
      barrier.evaluate(*robot, robot->forward(b), sm, gm, kelvin::Gradient::cell);
      for (int r = 0; r < barrier.rows(); ++r) fd(r, i) = (sp[r].h - sm[r].h) / (2 * eps);
    }
    const robot::Kinematics k = robot->forward(q);
    for (int r = 0; r < barrier.rows(); ++r) {
      const double scale = std::max(1.0, fd.row(r).norm());
      worst = std::max(worst, (g.row(r) - fd.row(r)).norm() / scale);
      // The same row with the object-frame gradient left unrotated: must be far off.
      const Vec3 x = barrier.world_point(k, r);
      const Vec3 object_gradient = scene().pose.dir_to_local(s[r].gradient);
      const robot::Jac J = robot->point_jacobian(k, barrier.points()[r].link, x);
      const Eigen::RowVectorXd wrong = object_gradient.transpose() * J.topRows<3>();
      worst_unrotated = std::min(worst_unrotated, (wrong - fd.row(r)).norm() / scale);
      ++checked;
    }
  }
  EXPECT_GT(checked, 200);
  EXPECT_LT(worst, 1e-5) << "∇h(x)ᵀ J_x(q) against central differences of h(x(q))";
  EXPECT_GT(worst_unrotated, 1e-3) << "the test would not see a gradient left in the object's frame";
}

TEST(FieldRows, SmoothedGradientIsCloserToTheClosedFormThanTheCellDerivative) {
  // For a sphere with constant σ, h = σ + ln(r/R) (sphere_fixture.hpp): the row the controller
  // uses (smoothed ∇h) is nearer the exact row than the derivative of the interpolated h.
  const auto robot = hand_robot();
  FieldBarrier barrier({scene().scene_field()}, points(*robot));
  std::vector<FieldPointSample> s;
  Eigen::MatrixXd smoothed, cell;
  double err_smoothed = 0, err_cell = 0;
  for (const VecQ& q : configurations(*robot, barrier, 20)) {
    const robot::Kinematics k = robot->forward(q);
    barrier.evaluate(*robot, k, s, smoothed, kelvin::Gradient::smoothed);
    for (int r = 0; r < barrier.rows(); ++r)
      EXPECT_NEAR(s[r].h, scene().sphere.h(scene().pose.to_local(barrier.world_point(k, r))), 0.02);
    barrier.evaluate(*robot, k, s, cell, kelvin::Gradient::cell);
    for (int r = 0; r < barrier.rows(); ++r) {
      const Vec3 x = barrier.world_point(k, r);
      const Vec3 exact = scene().pose.dir_to_world(scene().sphere.gradient(scene().pose.to_local(x)));
      const Eigen::RowVectorXd row = exact.transpose() * robot->point_jacobian(k, barrier.points()[r].link, x).topRows<3>();
      err_smoothed += (smoothed.row(r) - row).squaredNorm();
      err_cell += (cell.row(r) - row).squaredNorm();
    }
  }
  EXPECT_LT(err_smoothed, 0.5 * err_cell);
}

// The hand above the table of wrench_grasp, the sphere beside it with δ = 0.05, no self pairs.
Scenario sphere_scenario() {
  Scenario sc;
  sc.robot = hand_robot();
  sc.q0 = VecQ::Zero(sc.robot->dof());
  sc.q0 << 0, 0.123, 0, -2.4389, 0, 2.562, 0.7854, 0.0055;
  sc.target.position = Vec3(0.5, 0, 0.3);
  sc.self_collision = false;
  sc.fields = {scene().scene_field(0.05)};
  sc.control_points = points(*sc.robot);
  return sc;
}

TEST(FieldRows, RowsAreAppendedBetweenPairsAndJointLimits) {
  const Scenario sc = sphere_scenario();
  const auto& robot = sc.robot;
  CbfController controller(sc, Metric::euclidean);
  Eigen::MatrixXd C;
  Eigen::VectorXd d;
  controller.rows(sc.q0, C, d);
  const int nf = controller.field_rows();
  ASSERT_EQ(nf, static_cast<int>(sc.control_points.size()));
  ASSERT_EQ(C.rows(), nf + joint_limit_rows(*robot));
  FieldBarrier barrier(sc.fields, sc.control_points);
  std::vector<FieldPointSample> s;
  Eigen::MatrixXd g;
  barrier.evaluate(*robot, robot->forward(sc.q0), s, g);
  for (int r = 0; r < nf; ++r) {
    EXPECT_EQ(C.row(r), g.row(r));
    EXPECT_DOUBLE_EQ(d[r], -sc.eta * (s[r].h - 0.05));
  }
}

TEST(FieldRows, SampledPointsLieOnTheElementsSurfaces) {
  const auto robot = hand_robot();
  const auto pts = sample_control_points(*robot, "panda_leftfinger", "panda_leftfinger_pad", 40, "cp");
  ASSERT_EQ(pts.size(), 40U);
  const robot::LinkPrimitive* pad = nullptr;
  for (const auto& p : robot->primitives())
    if (p.name == "panda_leftfinger_pad") pad = &p;
  ASSERT_NE(pad, nullptr);
  const Vec3 half = std::get<Box>(pad->shape).size / 2;
  int inner_face = 0;
  for (const auto& c : pts) {
    const Vec3 local = pad->pose.to_local(c.point);
    // On the box's boundary: inside it, with one coordinate at its face.
    EXPECT_LE((local.cwiseAbs() - half).maxCoeff(), 1e-12);
    EXPECT_NEAR((local.cwiseAbs() - half).maxCoeff(), 0, 1e-12);
    inner_face += std::abs(local.y() + half.y()) < 1e-12;
  }
  EXPECT_GT(inner_face, 4);
  EXPECT_THROW(sample_control_points(*robot, "panda_leftfinger", "nope", 4, "cp"), InvalidInput);
  EXPECT_THROW(sample_control_points(*robot, "no_link", "", 4, "cp"), InvalidInput);
  EXPECT_THROW(sample_control_points(*robot, "panda_hand_tcp", "", 4, "cp"), InvalidInput);  // no collision elements
}

TEST(FieldRows, StartInsideTheUnsafeSetIsRefusedBeforeTheRun) {
  Scenario sc = sphere_scenario();
  sc.duration = 0.05;
  EXPECT_NO_THROW(require_safe_start(sc, sc.q0));
  sc.fields[0].margin = 50;  // no point has h ≥ 50 anywhere near the arm
  try {
    rollout(sc, Metric::euclidean);
    FAIL() << "a start outside the safe set was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "control_points");
    EXPECT_NE(std::string(e.what()).find("unsafe set of field \"sphere\""), std::string::npos) << e.what();
  }
}

TEST(FieldRows, APointInsideTheObjectHasNoRow) {
  const auto robot = hand_robot();
  const VecQ q = (VecQ(robot->dof()) << 0, 0.123, 0, -2.4389, 0, 2.562, 0.7854, 0.0055).finished();
  const robot::Kinematics k = robot->forward(q);
  // A point fixed to the hand, placed at the sphere's centre in the world at this q.
  const Vec3 centre = scene().pose.to_world(scene().sphere.centre);
  const int hand = robot->link_index("panda_hand");
  ControlPoint c{"at_centre", hand, k.frames[static_cast<std::size_t>(hand)].to_local(centre)};
  FieldBarrier barrier({scene().scene_field()}, {c});
  std::vector<FieldPointSample> s;
  Eigen::MatrixXd g;
  barrier.evaluate(*robot, k, s, g);
  EXPECT_EQ(s[0].status, kelvin::Status::inside);
  EXPECT_TRUE(g.row(0).isZero());
  EXPECT_THROW(require_defined(s, barrier.fields(), barrier.points()), FieldUndefined);
}

}  // namespace
}  // namespace distlab::cbf
