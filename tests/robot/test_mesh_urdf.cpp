// A URDF with <mesh> collision elements, written by the test (mesh_robot.hpp): the tree and its
// joints as written, forward kinematics against the test's own 4×4 matrices, each hull's vertices
// against the scaled mesh's extreme points, point Jacobians through the prismatic, continuous
// and mimic joints against differences, distances of the mesh links against gap_distance and
// FCL on the same hull built here; and errors naming the URDF element for files, packages,
// meshes and joints outside the subset.
#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "mesh_robot.hpp"

#include "distlab/gap/distance.hpp"
#include "distlab/geometry/polytope.hpp"
#include "distlab/robot/distances.hpp"

namespace distlab::robot {
namespace {

using test::MeshRobot;

class MeshUrdf : public ::testing::Test {
 protected:
  void SetUp() override {
    spec = test::write_mesh_robot(dir);
    robot = Robot::from_file(spec.urdf_path, "robot", spec.options);
  }
  // The element's pose in the world by the test's matrices.
  Pose element_pose(const test::ElementSpec& e, const std::map<std::string, test::Mat4>& T) const {
    const test::Mat4 M = T.at(e.link) * test::origin(e.xyz, e.rpy);
    Pose p;
    p.position = M.block<3, 1>(0, 3);
    p.rotation = Quat(Mat3(M.block<3, 3>(0, 0)));
    return p;
  }
  std::vector<Vec3> scaled(const test::ElementSpec& e, const std::vector<Vec3>& points) const {
    std::vector<Vec3> out;
    for (const Vec3& v : points) out.emplace_back(v.cwiseProduct(e.scale));
    return out;
  }
  test::TempDir dir;
  MeshRobot spec;
  std::shared_ptr<const Robot> robot;
};

TEST_F(MeshUrdf, TheTreeAsWritten) {
  ASSERT_EQ(robot->dof(), 4);
  EXPECT_EQ(robot->joint_names(), (std::vector<std::string>{"j1", "j6", "j2", "j3"}));  // file order
  EXPECT_EQ(robot->joint_types(), (std::vector<JointType>{JointType::revolute, JointType::revolute,
                                                          JointType::prismatic, JointType::revolute}));
  EXPECT_EQ(robot->q_min()[0], -2);
  EXPECT_EQ(robot->q_max()[2], 0.3);
  EXPECT_EQ(robot->q_min()[3], -std::numeric_limits<double>::infinity());  // continuous
  EXPECT_EQ(robot->q_max()[3], std::numeric_limits<double>::infinity());
  EXPECT_EQ(robot->links()[robot->ee_link()], "l6");  // the last leaf in file order
  const std::vector<std::string> names = {"l1/collision[0]", "wedge", "l3/collision[0]", "l3_box",
                                          "l4/collision[0]", "pyramid", "ball"};
  ASSERT_EQ(robot->primitives().size(), names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    const LinkPrimitive& p = robot->primitives()[i];
    EXPECT_EQ(p.name, names[i]);
    EXPECT_EQ(robot->links()[p.link], spec.elements[i].link);
    EXPECT_EQ(p.mesh, spec.elements[i].filename);
    EXPECT_EQ(std::holds_alternative<Polytope>(p.shape), !spec.elements[i].filename.empty()) << p.name;
  }
  EXPECT_EQ(robot->primitives()[3].element, 1);  // l3's second <collision>
  // Links at least two moving joints apart (the mimic j4 moves l4 and l5; j5 is fixed), by hand:
  // l1–l3, l1–l4, l1–l5, l2–l4, l2–l5, l2–l6, l3–l6, l4–l6, l5–l6 over the elements 0 … 6.
  const std::vector<std::pair<int, int>> pairs = {{0, 2}, {0, 3}, {0, 4}, {0, 5}, {1, 4}, {1, 5}, {1, 6}, {2, 6}, {3, 6}, {4, 6}, {5, 6}};
  EXPECT_EQ(robot->self_pairs(), pairs);
}

// package://pkg/... found below a folder of packages (ROS_PACKAGE_PATH's way): the same robot.
TEST_F(MeshUrdf, PackagesFoundThroughSearchDirectories) {
  UrdfOptions options;
  options.package_search_dirs = {dir.path() + "/nowhere", dir.path() + "/share"};
  const auto found = Robot::from_file(spec.urdf_path, "robot", options);
  ASSERT_EQ(found->primitives().size(), robot->primitives().size());
  for (const int i : {1, 5}) {  // the package:// elements
    const auto& a = std::get<Polytope>(found->primitives()[i].shape);
    const auto& b = std::get<Polytope>(robot->primitives()[i].shape);
    EXPECT_EQ(a.vertices, b.vertices) << i;
  }
  options.package_search_dirs = {dir.path()};  // no folder pkg there
  const test::Refusal r = test::refusal([&] { Robot::from_file(spec.urdf_path, "robot", options); });
  EXPECT_EQ(r.field, "robot");
  EXPECT_NE(r.message.find("package \"pkg\""), std::string::npos) << r.message;
}

TEST_F(MeshUrdf, ForwardKinematicsMatchesTheMatrices) {
  // The same text through from_urdf with the folder given explicitly.
  UrdfOptions options = spec.options;
  options.base_dir = dir.path() + "/robot";
  const auto from_text = Robot::from_urdf(spec.urdf, "robot", options);
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 30; ++trial) {
    VecQ q = test::random_q(rng, *robot);
    if (trial % 3 == 0) q[3] += 4 * M_PI;  // a continuous joint past ±π
    const auto T = test::spec_fk(spec, q);
    const Kinematics k = robot->forward(q), k2 = from_text->forward(q);
    for (const std::string& link : spec.links) {
      const int l = robot->link_index(link);
      ASSERT_GE(l, 0) << link;
      EXPECT_LT((k.frames[l].position - T.at(link).block<3, 1>(0, 3)).norm(), 1e-12) << link << " trial " << trial;
      EXPECT_LT((k.R[l] - T.at(link).block<3, 3>(0, 0)).norm(), 1e-12) << link << " trial " << trial;
      EXPECT_LT((k.frames[l].R() - T.at(link).block<3, 3>(0, 0)).norm(), 1e-12) << link << " trial " << trial;
      EXPECT_EQ(k.frames[l].position, k2.frames[l].position);
    }
    for (std::size_t i = 0; i < spec.elements.size(); ++i) {
      const Pose expected = element_pose(spec.elements[i], T);
      const Pose got = robot->primitive_pose(k, static_cast<int>(i));
      EXPECT_LT((got.position - expected.position).norm(), 1e-12) << spec.elements[i].name;
      EXPECT_LT((got.R() - expected.R()).norm(), 1e-12) << spec.elements[i].name;
    }
  }
}

TEST_F(MeshUrdf, PointJacobiansThroughPrismaticContinuousAndMimicJoints) {
  std::mt19937_64 rng(4);
  for (int trial = 0; trial < 10; ++trial) {
    const VecQ q = test::random_q(rng, *robot);
    for (int link = 0; link < static_cast<int>(robot->links().size()); ++link)
      test::expect_jacobian_matches_differences(*robot, q, link, Vec3(0.03, -0.02, 0.05));
  }
  // The mimic: at the same point, l4's column of j1 is l3's plus −0.5 × j4's world axis, which
  // is l3's x axis turned by j4's origin (rpy 0 0.9 0), here from the matrices.
  const VecQ q = VecQ::Zero(4);
  const Kinematics k = robot->forward(q);
  const int l4 = robot->link_index("l4"), l3 = robot->link_index("l3");
  const Vec3 p = k.frames[l4].position + Vec3(0.1, 0.2, -0.1);
  const Jac J4 = robot->point_jacobian(k, l4, p), J3 = robot->point_jacobian(k, l3, p);
  const test::Mat4 T4 = test::spec_fk(spec, q).at("l3") * test::origin(Vec3(0.12, 0, 0), Vec3(0, 0.9, 0));
  const Vec3 a = T4.block<3, 3>(0, 0) * Vec3::UnitX(), o = T4.block<3, 1>(0, 3);
  EXPECT_LT((J4.block<3, 1>(3, 0) - J3.block<3, 1>(3, 0) - (-0.5) * a).norm(), 1e-12);
  EXPECT_LT((J4.block<3, 1>(0, 0) - J3.block<3, 1>(0, 0) - (-0.5) * a.cross(p - o)).norm(), 1e-12);
}

TEST_F(MeshUrdf, HullsAreTheScaledMeshesExtremePoints) {
  int meshes = 0;
  for (std::size_t i = 0; i < spec.elements.size(); ++i) {
    const test::ElementSpec& e = spec.elements[i];
    if (e.filename.empty()) continue;
    ++meshes;
    const auto* hull = std::get_if<Polytope>(&robot->primitives()[i].shape);
    ASSERT_NE(hull, nullptr) << e.filename;
    const std::vector<Vec3> extreme = scaled(e, e.extreme);
    ASSERT_EQ(hull->vertices.size(), extreme.size()) << e.filename;
    for (const Vec3& v : extreme) {
      double nearest = INFINITY;
      for (const Vec3& h : hull->vertices) nearest = std::min(nearest, (h - v).norm());
      EXPECT_LT(nearest, 1e-15) << e.filename << " extreme point " << v.transpose();
    }
    // Every row a facet of the scaled mesh: all of its points inside, at least three on it.
    const std::vector<Vec3> points = scaled(e, e.mesh.vertices);
    for (int r = 0; r < hull->rows(); ++r) {
      int on = 0;
      for (const Vec3& p : points) {
        const double s = hull->A.row(r).dot(p) - hull->b[r];
        EXPECT_LE(s, 1e-15) << e.filename << " row " << r;
        on += std::abs(s) <= 1e-15;
      }
      EXPECT_GE(on, 3) << e.filename << " row " << r;
    }
  }
  EXPECT_EQ(meshes, 5);
}

// distances() of every mesh element (cold, GAP and Euclidean) against the same hull built here
// from the file's numbers: GAP as gap_distance of that hull at the element's pose (the matrices'
// FK), Euclidean as FCL on the hull of the points moved to the world; the gradient as the pose
// gradient through the point Jacobian of the element's origin.
TEST_F(MeshUrdf, MeshDistancesEqualThoseOfTheSameHull) {
  const GapParams params;
  std::vector<Obstacle> obstacles = {{"ball", Sphere{0.05}, {Vec3(0.45, -0.1, 0.55), Quat::Identity()}},
                                     {"slab", Box{Vec3(0.3, 0.2, 0.04)}, {Vec3(0.1, 0.1, -0.2), Quat(0.9, 0.1, -0.3, 0.2).normalized()}}};
  std::mt19937_64 rng(8);
  std::vector<double> qs;
  const int n = 12;
  for (int i = 0; i < n; ++i) {
    const VecQ q = test::random_q(rng, *robot);
    qs.insert(qs.end(), q.data(), q.data() + q.size());
  }
  int checked_gap = 0, checked_euclid = 0;
  for (const Metric metric : {Metric::gap, Metric::euclidean}) {
    const DistanceModel model(robot, obstacles, metric, params, PairSelection{});
    BatchOptions options;
    options.threads = 1;
    options.tracking = false;
    const DistanceBatch b = distances(model, qs, n, options);
    for (int c = 0; c < n; ++c) {
      const VecQ q = Eigen::Map<const VecQ>(qs.data() + c * 4, 4);
      const auto T = test::spec_fk(spec, q);
      const Kinematics k = robot->forward(q);
      for (int p = 0; p < b.pairs; ++p) {
        const RobotPair& pair = model.pairs()[p];
        const test::ElementSpec& e = spec.elements[pair.a];
        if (e.filename.empty()) continue;
        const Pose pose = element_pose(e, T);
        const Obstacle& o = obstacles[pair.b];
        const std::size_t cell = static_cast<std::size_t>(c) * b.pairs + p;
        const Vec3 wa(&b.witness_robot[cell * 3]), wb(&b.witness_obstacle[cell * 3]);
        const Eigen::Map<const Eigen::RowVectorXd> row(&b.jacobian[cell * 4], 4);
        const Jac J = robot->point_jacobian(k, robot->primitives()[pair.a].link, robot->primitive_pose(k, pair.a).position);
        if (metric == Metric::gap) {
          const GapBody A(polytope_from_points(scaled(e, e.mesh.vertices), "hull"), pose, params);
          const GapBody B(o.shape, o.pose, params, gap_body_options(o.shape, {}, params));
          const GapResult r = gap_distance(A, B, params);
          ASSERT_TRUE(r.converged);
          if (r.overlap) {
            EXPECT_EQ(b.distance[cell], 0) << model.pairs()[p].name;
            continue;
          }
          // Both solved to tol 1e-10 in the witnesses from one start; D is stationary in them.
          EXPECT_NEAR(b.distance[cell], r.distance, 1e-12 * r.distance) << model.pairs()[p].name;
          EXPECT_LT((wa - r.witness_a).norm(), 1e-10) << model.pairs()[p].name;
          EXPECT_LT((wb - r.witness_b).norm(), 1e-10) << model.pairs()[p].name;
          const Eigen::RowVectorXd expected = r.gradient_a.transpose() * J;
          EXPECT_LT((row - expected).cwiseAbs().maxCoeff(), 1e-9 * expected.cwiseAbs().maxCoeff()) << model.pairs()[p].name;
          ++checked_gap;
        } else {
          std::vector<Vec3> world;
          for (const Vec3& v : scaled(e, e.mesh.vertices)) world.push_back(pose.to_world(v));
          const EuclideanShape A(polytope_from_points(world, "hull")), B(o.shape);
          const EuclideanResult r = euclidean_distance(A, Pose{}, B, o.pose);
          if (r.distance <= 0) {
            EXPECT_EQ(b.distance[cell], 0) << model.pairs()[p].name;
            continue;
          }
          // FCL's answers are certified to a duality gap of 1e-14 relative (collision/
          // euclidean_distance.cpp): the distance to that, the direction of the nearest points
          // (and so the witnesses on round shapes and the gradient) to ~sqrt(1e-14) = 1e-7.
          EXPECT_NEAR(b.distance[cell], r.distance, 1e-13) << model.pairs()[p].name;
          EXPECT_LT((wa - r.witness_a).norm(), 1e-7 * 0.1) << model.pairs()[p].name;
          EXPECT_LT((wb - r.witness_b).norm(), 1e-7 * 0.1) << model.pairs()[p].name;
          // The world hull's gradient is about the world origin: translate it to the element's.
          Vec6 g = r.gradient_a;
          g.tail<3>() += (Vec3::Zero() - pose.position).cross(g.head<3>());
          const Eigen::RowVectorXd expected = g.transpose() * J;
          EXPECT_LT((row - expected).cwiseAbs().maxCoeff(), 2e-7 * expected.cwiseAbs().maxCoeff()) << model.pairs()[p].name;
          ++checked_euclid;
        }
      }
    }
  }
  EXPECT_GT(checked_gap, 5 * n);
  EXPECT_GT(checked_euclid, 5 * n);
}

// A model rebuilt for an obstacle that moved (a controller's moving target) takes each mesh
// hull's weights from the first model's work: no hull is weighed twice, and the distances are
// those of a model built from nothing. Its FCL geometry is the Robot's.
TEST_F(MeshUrdf, AModelForMovedObstaclesReusesTheHullsWeightsAndFclGeometry) {
  const GapParams params;
  const auto obstacles_at = [](double x) {
    return std::vector<Obstacle>{{"ball", Sphere{0.05}, {Vec3(x, -0.1, 0.55), Quat::Identity()}}};
  };
  const VecQ q = VecQ::Constant(robot->dof(), 0.3);
  clear_hull_weight_cache();
  const DistanceModel first(robot, obstacles_at(0.45), Metric::gap, params, PairSelection{});
  const CacheStats built = hull_weight_cache_stats();
  EXPECT_GE(built.misses, 2u);  // the test robot's mesh elements
  const DistanceModel moved(robot, obstacles_at(0.5), Metric::gap, params, PairSelection{});
  const CacheStats reused = hull_weight_cache_stats();
  EXPECT_EQ(reused.misses, built.misses);
  EXPECT_EQ(reused.hits, built.hits + built.misses);

  const DistanceBatch warm = distances(moved, std::span<const double>(q.data(), q.size()), 1);
  clear_hull_weight_cache();
  const DistanceModel fresh(robot, obstacles_at(0.5), Metric::gap, params, PairSelection{});
  const DistanceBatch cold = distances(fresh, std::span<const double>(q.data(), q.size()), 1);
  EXPECT_EQ(warm.distance, cold.distance);
  EXPECT_EQ(warm.jacobian, cold.jacobian);

  // Nor does it build the robot's FCL geometry again: every model's elements, and the GAP bodies of
  // its workspaces, hold the Robot's own (read-only) geometry.
  const DistanceModel::Workspace w = moved.workspace();
  for (int i = 0; i < static_cast<int>(robot->primitives().size()); ++i) {
    const auto* own = robot->euclidean_shape(i).fcl_geometry().get();
    ASSERT_NE(own, nullptr);
    EXPECT_EQ(first.robot_shape(i).fcl_geometry().get(), own) << i;
    EXPECT_EQ(moved.robot_shape(i).fcl_geometry().get(), own) << i;
    EXPECT_EQ(w.robot_gap[static_cast<std::size_t>(i)].euclidean().fcl_geometry().get(), own) << i;
  }
}

// The text of the test's URDF with `from` replaced by `to` (once), parsed with its options.
test::Refusal parse_changed(const MeshRobot& spec, const std::string& base_dir, const std::string& from,
                            const std::string& to) {
  std::string xml = spec.urdf;
  const std::size_t at = xml.find(from);
  if (at == std::string::npos) return {"test error", from + " is not in the URDF"};
  xml.replace(at, from.size(), to);
  UrdfOptions options = spec.options;
  options.base_dir = base_dir;
  return test::refusal([&] { Robot::from_urdf(xml, "robot", options); });
}

// The field is the caller's ("robot"); the message names the element and every part given.
void expect_refused(const test::Refusal& r, const std::vector<std::string>& parts) {
  EXPECT_EQ(r.field, "robot") << r.message;
  for (const std::string& part : parts) EXPECT_NE(r.message.find(part), std::string::npos) << part << " not in: " << r.message;
}

TEST_F(MeshUrdf, ErrorsNameTheUrdfElement) {
  const std::string base = dir.path() + "/robot";
  const std::string l1 = "collision[0] of link \"l1\"";
  expect_refused(parse_changed(spec, base, "meshes/dented.stl", "meshes/missing.stl"),
                 {l1, "\"meshes/missing.stl\"", "no such file"});
  {  // Where it looked, and that the folder is not there.
    UrdfOptions options = spec.options;
    options.base_dir = base;
    for (auto& [name, folder] : options.package_dirs) folder = dir.path() + "/no_such_folder";
    expect_refused(test::refusal([&] { Robot::from_urdf(spec.urdf, "robot", options); }),
                   {"\"wedge\"", "\"" + dir.path() + "/no_such_folder/meshes/wedge.stl\"", "no such file",
                    "its folder \"" + dir.path() + "/no_such_folder/meshes/\" does not exist"});
  }
  expect_refused(parse_changed(spec, base, "package://pkg/meshes/wedge.stl", "package://nowhere/meshes/wedge.stl"),
                 {"collision[0] \"wedge\" of link \"l2\"", "package \"nowhere\" is not in package_dirs"});
  expect_refused(parse_changed(spec, base, "package://pkg/meshes/wedge.stl", "package://pkg/../robot/meshes/box.obj"),
                 {"\"wedge\"", "no \"..\""});
  for (const std::string bad : {"package://", "package:///", "package://pkg", "package://pkg/"})
    expect_refused(parse_changed(spec, base, "package://pkg/meshes/wedge.stl", bad), {"\"wedge\"", "\"" + bad + "\""});
  // A relative filename in text without a folder.
  expect_refused(parse_changed(spec, "", "meshes/dented.stl", "meshes/dented.stl"), {l1, "is relative"});

  // Open: a tetrahedron without its fourth face. Its hull is taken, with a warning naming the
  // element; refused with require_closed_meshes.
  test::PolyMesh open;
  open.vertices = {Vec3(0, 0, 0), Vec3(0.1, 0, 0), Vec3(0, 0.1, 0), Vec3(0, 0, 0.1)};
  open.faces = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}};
  dir.write("robot/meshes/open.off", test::off(open));
  std::string xml = spec.urdf;
  xml.replace(xml.find("meshes/dented.stl"), 17, "meshes/open.off");
  UrdfOptions options = spec.options;
  options.base_dir = base;
  const auto opened = Robot::from_urdf(xml, "robot", options);
  ASSERT_EQ(opened->warnings().size(), 1u);
  for (const std::string& part : std::vector<std::string>{l1, "\"meshes/open.off\"", "is not closed", "3 edges"})
    EXPECT_NE(opened->warnings()[0].find(part), std::string::npos) << part << " not in: " << opened->warnings()[0];
  EXPECT_EQ(std::get<Polytope>(opened->primitives()[0].shape).vertices.size(), 4u);
  EXPECT_TRUE(robot->warnings().empty());
  options.require_closed_meshes = true;
  expect_refused(test::refusal([&] { Robot::from_urdf(xml, "robot", options); }),
                 {l1, "\"meshes/open.off\"", "is not closed", "3 edges"});

  // Flat: a closed two-sided square, every vertex in z = 0.
  test::PolyMesh flat;
  flat.vertices = {Vec3(0, 0, 0), Vec3(0.1, 0, 0), Vec3(0.1, 0.1, 0), Vec3(0, 0.1, 0)};
  flat.faces = {{0, 1, 2, 3}, {0, 3, 2, 1}};
  dir.write("robot/meshes/flat.obj", test::obj(flat));
  expect_refused(parse_changed(spec, base, "meshes/dented.stl", "meshes/flat.obj"), {l1, "\"meshes/flat.obj\"", "is degenerate"});

  // Not a mesh.
  dir.write("robot/meshes/junk.stl", "this is not an STL file");
  expect_refused(parse_changed(spec, base, "meshes/dented.stl", "meshes/junk.stl"), {l1, "\"meshes/junk.stl\""});

  for (const std::string type : {"floating", "planar"})
    expect_refused(parse_changed(spec, base, R"(name="j6" type="revolute")", R"(name="j6" type=")" + type + "\""),
                   {"joint \"j6\"", "\"" + type + "\"", "supported: revolute, continuous, prismatic, fixed"});
  expect_refused(parse_changed(spec, base, R"(<mimic joint="j1")", R"(<mimic joint="j99")"), {"joint \"j4\"", "\"j99\""});
  // A mimic of a fixed joint.
  expect_refused(parse_changed(spec, base, R"(<mimic joint="j1")", R"(<mimic joint="j5")"), {"joint \"j4\"", "\"j5\""});
  expect_refused(parse_changed(spec, base, R"(scale="0.5 1 2")", R"(scale="0.5 0 2")"), {l1, "scale"});

  // Unchanged, it parses.
  EXPECT_EQ(parse_changed(spec, base, "<robot", "<robot").field, "accepted");
}

}  // namespace
}  // namespace distlab::robot
