// POST /api/robot/distances and GET /api/robot/robots (issue 32, item 5) against the real server:
// the numbers are the robot library's distances() on the same input, bit for bit; a URDF whose
// mesh comes from the upload route gives the closed-form Euclidean distance of its hull and the
// GAP route's distance of the same hull; the Jacobian is laid out as (N, P, dof) (central
// differences of the route's own distances); every bad input is a 4xx naming its field, and every
// limit is enforced.
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "distlab/robot/distances.hpp"
#include "server/server_fixture.hpp"

namespace distlab::test {
namespace {

class RobotApi : public SharedServerTest<RobotApi> {};

httplib::Result post(httplib::Client& c, const json& body, const std::string& session = "") {
  if (session.empty()) return c.Post("/api/robot/distances", body.dump(), "application/json");
  return c.Post("/api/robot/distances", session_headers(session), body.dump(), "application/json");
}

json box(const std::string& name, std::vector<double> size, std::vector<double> position) {
  return {{"type", "box"}, {"name", name}, {"size", size}, {"pose", {{"position", position}}}};
}

// Two Panda configurations in the corridor scenario's boxes (its q0 and another).
const std::vector<double> kQ = {1.0582, -1.3811, 0.3629, -1.9647, -0.959, 1.4881, -0.1534,
                                0.4, 0.1, -0.2, -1.9, 0.1, 1.8, 0.5};
json panda_request() {
  return {{"robot", "panda"},
          {"q", {std::vector<double>(kQ.begin(), kQ.begin() + 7), std::vector<double>(kQ.begin() + 7, kQ.end())}},
          {"obstacles", {box("wall1", {0.32, 0.08, 0.92}, {0.52, 0.19, 0.48}), box("wall2", {0.32, 0.08, 0.92}, {0.52, -0.19, 0.48}), box("roof", {0.32, 0.46, 0.08}, {0.52, 0.0, 0.96})}}};
}

std::vector<robot::Obstacle> panda_obstacles() {
  const auto at = [](double x, double y, double z) {
    Pose p;
    p.position = Vec3(x, y, z);
    return p;
  };
  return {{"wall1", Box{Vec3(0.32, 0.08, 0.92)}, at(0.52, 0.19, 0.48), {}},
          {"wall2", Box{Vec3(0.32, 0.08, 0.92)}, at(0.52, -0.19, 0.48), {}},
          {"roof", Box{Vec3(0.32, 0.46, 0.08)}, at(0.52, 0.0, 0.96), {}}};
}

std::shared_ptr<const robot::Robot> panda() {
  return robot::Robot::load(std::string(DISTLAB_SOURCE_DIR) + "/assets/robots/panda.urdf");
}

// The route's answer equals the library's batch on the same input, number for number (the same
// work split: one chunk, every core).
void expect_same_as_library(const json& got, const robot::DistanceModel& model, const std::vector<double>& q, int n) {
  const robot::DistanceBatch b = robot::distances(model, q, n);
  const std::size_t np = model.pairs().size(), dof = static_cast<std::size_t>(model.dof());
  ASSERT_EQ(got["n"], n);
  ASSERT_EQ(got["pairs"].size(), np);
  for (std::size_t p = 0; p < np; ++p) EXPECT_EQ(got["pairs"][p]["name"], model.pairs()[p].name);
  for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i)
    for (std::size_t p = 0; p < np; ++p) {
      const std::size_t c = i * np + p;
      EXPECT_EQ(got["distance"][i][p].get<double>(), b.distance[c]) << i << " " << p;
      for (std::size_t k = 0; k < dof; ++k) EXPECT_EQ(got["jacobian"][i][p][k].get<double>(), b.jacobian[c * dof + k]);
      ASSERT_EQ(got["obstacle_gradient"][i][p].size(), 6u);
      for (std::size_t k = 0; k < 6; ++k)
        EXPECT_EQ(got["obstacle_gradient"][i][p][k].get<double>(), b.obstacle_gradient[c * 6 + k]);
      for (std::size_t k = 0; k < 3; ++k) {
        EXPECT_EQ(got["witness_robot"][i][p][k].get<double>(), b.witness_robot[c * 3 + k]);
        EXPECT_EQ(got["witness_obstacle"][i][p][k].get<double>(), b.witness_obstacle[c * 3 + k]);
      }
      EXPECT_EQ(got["overlap"][i][p].get<bool>(), b.overlap[c] != 0);
      EXPECT_EQ(got["converged"][i][p].get<bool>(), b.converged[c] != 0);
      EXPECT_EQ(got["iterations"][i][p].get<int>(), b.iterations[c]);
    }
}

TEST_F(RobotApi, PandaAmongBoxesIsTheLibrarysBatch) {
  for (const char* metric : {"gap", "euclidean"}) {
    json req = panda_request();
    req["metric"] = metric;
    auto r = post(c, req);
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    const json got = body_json(r);
    EXPECT_EQ(got["robot"], "panda");
    EXPECT_EQ(got["dof"], 7);
    EXPECT_EQ(got["metric"], metric);
    EXPECT_EQ(got["joint_names"], json(panda()->joint_names()));
    const robot::Metric m = std::string(metric) == "gap" ? robot::Metric::gap : robot::Metric::euclidean;
    const robot::DistanceModel model(panda(), panda_obstacles(), m, GapParams{}, {});
    EXPECT_EQ(got["pairs"].size(), panda()->primitives().size() * 3);
    expect_same_as_library(got, model, kQ, 2);
    // Each obstacle pair names its element's link and its obstacle.
    const json& first = got["pairs"][0];
    EXPECT_EQ(first["self"], false);
    EXPECT_EQ(first["obstacle"], "wall1");
    EXPECT_EQ(first["element"], panda()->primitives()[0].name);
    EXPECT_EQ(first["link"], panda()->links()[static_cast<std::size_t>(panda()->primitives()[0].link)]);
  }
}

TEST_F(RobotApi, OneConfigurationSelfPairsAndTheirSelection) {
  json req = panda_request();
  req["q"] = std::vector<double>(kQ.begin(), kQ.begin() + 7);  // one configuration: (1, P, ...) arrays
  req["pairs"] = "both";
  auto r = post(c, req);
  ASSERT_EQ(r->status, 200) << r->body;
  const json both = body_json(r);
  robot::PairSelection selection;
  selection.self = true;
  const robot::DistanceModel model(panda(), panda_obstacles(), robot::Metric::gap, GapParams{}, selection);
  expect_same_as_library(both, model, std::vector<double>(kQ.begin(), kQ.begin() + 7), 1);
  std::size_t self = 0;
  for (const json& p : both["pairs"])
    if (p["self"].get<bool>()) {
      ++self;
      EXPECT_FALSE(p.contains("obstacle"));
      EXPECT_EQ(p["name"], p["element"].get<std::string>() + "/" + p["other"]["element"].get<std::string>());
    }
  EXPECT_EQ(self, panda()->self_pairs().size());
  ASSERT_GT(self, 0u);

  // Only self pairs, less the ones between two links (deny), plus a pair of neighbours (allow).
  const json first_self = both["pairs"][panda()->primitives().size() * 3];
  const std::string la = first_self["link"], lb = first_self["other"]["link"];
  req["pairs"] = {{"obstacles", false}, {"self", true}, {"deny", json::array({json::array({lb, la})})}, {"allow", json::array({json::array({"panda_link1", "panda_link2"})})}};
  r = post(c, req);
  ASSERT_EQ(r->status, 200) << r->body;
  const json some = body_json(r);
  bool neighbours = false;
  for (const json& p : some["pairs"]) {
    EXPECT_TRUE(p["self"].get<bool>());
    const std::set<std::string> links = {p["link"], p["other"]["link"]};
    EXPECT_NE(links, (std::set<std::string>{la, lb}));
    neighbours = neighbours || links == std::set<std::string>{"panda_link1", "panda_link2"};
  }
  EXPECT_TRUE(neighbours);

  // Without gradients: no jacobian, the same distances.
  req = panda_request();
  req["params"] = {{"gradient", false}};
  r = post(c, req);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_FALSE(body_json(r).contains("jacobian"));
  EXPECT_FALSE(body_json(r).contains("obstacle_gradient"));
}

// The Jacobian's layout (N, P, dof): its entries are the route's own distances differenced at
// q ± h e_k (Euclidean: no solver tolerance in the difference).
TEST_F(RobotApi, JacobianIsTheDerivativeOfTheRoutesDistance) {
  const std::vector<double> q0(kQ.begin(), kQ.begin() + 7);  // the corridor's start: no pair overlaps
  const double h = 1e-6;
  json qs = json::array({q0});
  for (int k = 0; k < 7; ++k) {
    std::vector<double> a = q0, b = q0;
    a[static_cast<std::size_t>(k)] += h;
    b[static_cast<std::size_t>(k)] -= h;
    qs.push_back(a);
    qs.push_back(b);
  }
  json req = panda_request();
  req["q"] = qs;
  req["metric"] = "euclidean";
  auto r = post(c, req);
  ASSERT_EQ(r->status, 200) << r->body;
  const json got = body_json(r);
  std::size_t checked = 0;
  for (std::size_t p = 0; p < got["pairs"].size(); ++p) {
    if (got["overlap"][0][p].get<bool>()) continue;
    ++checked;
    for (std::size_t k = 0; k < 7; ++k) {
      const double fd = (got["distance"][1 + 2 * k][p].get<double>() - got["distance"][2 + 2 * k][p].get<double>()) / (2 * h);
      EXPECT_NEAR(got["jacobian"][0][p][k].get<double>(), fd, 1e-6) << got["pairs"][p]["name"] << " q" << k;
    }
  }
  EXPECT_EQ(checked, got["pairs"].size()) << "no pair overlaps at this configuration";
}

// A trajectory longer than one chunk of the batch (4096 evaluations between two checks of the
// time limit): Euclidean numbers are the library's one call bit for bit; GAP's continue their
// warm starts across chunks, so they agree with the library's to the solver's tolerance.
TEST_F(RobotApi, ChunkedTrajectoryIsTheLibrarysBatch) {
  const int n = 400;  // 400 × 27 pairs: three chunks
  std::vector<double> q;
  json qs = json::array();
  for (int i = 0; i < n; ++i) {
    std::vector<double> row(7);
    for (std::size_t k = 0; k < 7; ++k) row[k] = kQ[k] + (kQ[7 + k] - kQ[k]) * i / (n - 1.0);
    q.insert(q.end(), row.begin(), row.end());
    qs.push_back(row);
  }
  for (const robot::Metric m : {robot::Metric::euclidean, robot::Metric::gap}) {
    json req = panda_request();
    req["q"] = qs;
    req["metric"] = robot::to_string(m);
    auto r = post(c, req);
    ASSERT_EQ(r->status, 200) << r->body.substr(0, 300);
    const json got = body_json(r);
    const robot::DistanceModel model(panda(), panda_obstacles(), m, GapParams{}, {});
    if (m == robot::Metric::euclidean) {
      expect_same_as_library(got, model, q, n);
      continue;
    }
    const robot::DistanceBatch b = robot::distances(model, q, n);
    const std::size_t np = model.pairs().size();
    double worst = 0;
    for (std::size_t cell = 0; cell < static_cast<std::size_t>(n) * np; ++cell) {
      ASSERT_TRUE(b.converged[cell]);
      worst = std::max(worst, std::abs(got["distance"][cell / np][cell % np].get<double>() - b.distance[cell]));
    }
    EXPECT_LT(worst, 1e-9) << "GAP distances of two converged solves (tol " << GapParams{}.tol << ")";
  }
}

// A cube of half-size 0.1 (OBJ, closed) on a link that turns about z at 0.5 m from the base.
const char* kCubeObj =
    "v -0.1 -0.1 -0.1\nv 0.1 -0.1 -0.1\nv 0.1 0.1 -0.1\nv -0.1 0.1 -0.1\n"
    "v -0.1 -0.1 0.1\nv 0.1 -0.1 0.1\nv 0.1 0.1 0.1\nv -0.1 0.1 0.1\n"
    "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
// A tetrahedron missing a face: not closed (its hull is used, with a warning).
const char* kOpenObj = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\n";
// A flat square: no hull.
const char* kFlatObj = "v 0 0 0\nv 0.1 0 0\nv 0.1 0.1 0\nv 0 0.1 0\nf 1 2 3\nf 1 3 4\n";

std::string urdf(const std::string& filename, const std::string& joint = "revolute", const std::string& scale = "") {
  return R"(<?xml version="1.0"?>
<robot name="turntable">
  <link name="base"/>
  <joint name="turn" type=")" +
         joint + R"(">
    <parent link="base"/><child link="plate"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="1" effort="1"/>
  </joint>
  <link name="plate">
    <collision name="block"><geometry><mesh filename=")" +
         filename + "\"" + (scale.empty() ? "" : " scale=\"" + scale + "\"") + R"(/></geometry></collision>
  </link>
</robot>)";
}

std::string upload(httplib::Client& c, const std::string& session, const char* obj) {
  auto r = c.Post("/api/kelvin/uploads?format=obj", session_headers(session), obj, "application/octet-stream");
  EXPECT_TRUE(r && r->status == 201) << (r ? r->body : "no response");
  return r && r->status == 201 ? body_json(r)["upload"].get<std::string>() : "";
}

TEST_F(RobotApi, UrdfWithAnUploadedMeshIsItsHull) {
  const std::string s = new_session(c);
  const std::string cube = upload(c, s, kCubeObj);
  const std::string file = "package://demo/meshes/cube.obj";
  const double q = 0.3, radius = 0.05;
  const json sphere = {{"type", "sphere"}, {"radius", radius}, {"pose", {{"position", {1.0, 0, 0.5}}}}};
  json req = {{"robot", {{"urdf", urdf(file)}, {"meshes", {{file, cube}}}}}, {"q", json::array({q})}, {"obstacles", json::array({sphere})}, {"metric", "euclidean"}};
  auto r = post(c, req, s);
  ASSERT_EQ(r->status, 200) << r->body;
  json got = body_json(r);
  EXPECT_EQ(got["robot"], "turntable");
  EXPECT_EQ(got["warnings"], json::array());
  EXPECT_EQ(got["pairs"][0]["element"], "block");
  EXPECT_EQ(got["pairs"][0]["link"], "plate");
  // The sphere's centre in the cube's frame is (cos q, −sin q, 0): outside the square in x and y.
  const double dx = std::cos(q) - 0.1, dy = std::sin(q) - 0.1;
  EXPECT_NEAR(got["distance"][0][0].get<double>(), std::hypot(dx, dy) - radius, 1e-9);

  // GAP: the GAP route's distance of the same hull at the pose FK gives it.
  req["metric"] = "gap";
  r = post(c, req, s);
  ASSERT_EQ(r->status, 200) << r->body;
  got = body_json(r);
  json points = json::array();
  for (double x : {-0.1, 0.1})
    for (double y : {-0.1, 0.1})
      for (double z : {-0.1, 0.1}) points.push_back({x, y, z});
  const json pose = {{"position", {0, 0, 0.5}}, {"quaternion", {std::cos(q / 2), 0, 0, std::sin(q / 2)}}};
  const json hull = {{"type", "convex_hull"}, {"points", points}, {"pose", pose}};
  const json pair = {{"a", hull}, {"b", sphere}};
  auto g = c.Post("/api/gap/distance", pair.dump(), "application/json");
  ASSERT_EQ(g->status, 200) << g->body;
  EXPECT_NEAR(got["distance"][0][0].get<double>(), body_json(g)["distance"].get<double>(), 1e-9);

  // The URDF's scale applies to the upload (taken in the file's unit): half the cube.
  req = {{"robot", {{"urdf", urdf("cube.obj", "revolute", "0.5 0.5 0.5")}, {"meshes", {{"cube.obj", cube}}}}}, {"q", json::array({q})}, {"obstacles", json::array({sphere})}, {"metric", "euclidean"}};
  r = post(c, req, s);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_NEAR(body_json(r)["distance"][0][0].get<double>(), std::hypot(std::cos(q) - 0.05, std::sin(q) - 0.05) - radius, 1e-9);
}

// A 2 mm box (an IMU in a quadruped's description) breaks Property 2 at h = 0.1: the element
// takes its own h (robot::element_params), which the response's warnings give, and the request
// succeeds with the GAP metric and the default validation; the Euclidean metric has no h.
TEST_F(RobotApi, AMillimetreElementTakesItsOwnHWithAWarning) {
  const std::string imu = R"(<robot name="imu"><link name="base"/>
  <joint name="turn" type="revolute"><parent link="base"/><child link="plate"/><origin xyz="0 0 0.5"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1" effort="1"/></joint>
  <link name="plate"><collision name="chip"><origin xyz="0.1 0 0"/><geometry><box size="0.002 0.002 0.002"/></geometry></collision></link>
</robot>)";
  const json sphere = {{"type", "sphere"}, {"radius", 0.05}, {"pose", {{"position", {0.4, 0, 0.5}}}}};
  json req = {{"robot", {{"urdf", imu}}}, {"q", json::array({0.2})}, {"obstacles", json::array({sphere})}};
  auto r = post(c, req);
  ASSERT_EQ(r->status, 200) << r->body;
  const json got = body_json(r);
  ASSERT_EQ(got["warnings"].size(), 1u) << r->body;
  EXPECT_NE(got["warnings"][0].get<std::string>().find("collision element \"chip\": bounding radius"), std::string::npos) << r->body;
  EXPECT_NE(got["warnings"][0].get<std::string>().find("small against h = 0.1: its GAP function takes h = "), std::string::npos) << r->body;
  EXPECT_GT(got["distance"][0][0].get<double>(), 0.0);
  EXPECT_TRUE(got["converged"][0][0].get<bool>());
  req["metric"] = "euclidean";
  r = post(c, req);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(body_json(r)["warnings"], json::array());
}

TEST_F(RobotApi, UrdfErrorsNameTheirField) {
  const std::string s = new_session(c);
  const std::string cube = upload(c, s, kCubeObj);
  const std::string open = upload(c, s, kOpenObj);
  const std::string flat = upload(c, s, kFlatObj);
  const auto with = [](const json& robot) { return json{{"robot", robot}, {"q", json::array({0.1})}}; };
  // No session, an unknown or foreign upload, a mesh without its upload, an upload without its mesh.
  expect_error(post(c, with({{"urdf", urdf("cube.obj")}, {"meshes", {{"cube.obj", cube}}}})), 401, "session_required", "robot.meshes[\"cube.obj\"]");
  expect_error(post(c, with({{"urdf", urdf("cube.obj")}, {"meshes", {{"cube.obj", "0123"}}}}), s), 404, "unknown_upload", "robot.meshes[\"cube.obj\"]");
  const std::string other = new_session(c);
  expect_error(post(c, with({{"urdf", urdf("cube.obj")}, {"meshes", {{"cube.obj", cube}}}}), other), 404, "unknown_upload", "robot.meshes[\"cube.obj\"]");
  expect_error(post(c, with({{"urdf", urdf("cube.obj")}}), s), 400, "invalid_input", "robot.meshes");
  expect_error(post(c, with({{"urdf", urdf("cube.obj")}, {"meshes", {{"cube.obj", cube}, {"x.stl", cube}}}}), s), 400, "invalid_input", "robot.meshes[\"x.stl\"]");
  expect_error(post(c, with({{"urdf", urdf("cube.obj")}, {"meshes", {{"cube.obj", 3}}}}), s), 400, "invalid_input", "robot.meshes[\"cube.obj\"]");
  expect_error(post(c, with({{"urdf", urdf("cube.obj")}, {"meshes", {"cube.obj"}}}), s), 400, "invalid_input", "robot.meshes");
  // The mesh itself: flat (no hull) is its entry's error; open is taken (its hull) with a warning.
  expect_error(post(c, with({{"urdf", urdf("flat.obj")}, {"meshes", {{"flat.obj", flat}}}}), s), 400, "invalid_input", "robot.meshes[\"flat.obj\"]");
  auto r = post(c, with({{"urdf", urdf("open.obj")}, {"meshes", {{"open.obj", open}}}}), s);
  ASSERT_EQ(r->status, 200) << r->body;
  ASSERT_EQ(body_json(r)["warnings"].size(), 1u) << r->body;
  EXPECT_NE(body_json(r)["warnings"][0].get<std::string>().find("open.obj\" is not closed"), std::string::npos) << r->body;
  // The URDF: not text, not XML, a floating joint, a package:// path leaving its package, nesting
  // and attributes the XML parser would take seconds for, CDATA, a DOCTYPE, unknown keys.
  expect_error(post(c, with({{"urdf", 5}})), 400, "invalid_input", "robot.urdf");
  expect_error(post(c, with({{"urdf", "not xml at all"}})), 400, "invalid_input", "robot.urdf");
  expect_error(post(c, with({{"urdf", urdf("cube.obj", "floating")}, {"meshes", {{"cube.obj", cube}}}}), s), 400, "invalid_input", "robot.urdf");
  expect_error(post(c, with({{"urdf", urdf("package://demo/../../etc/passwd")}})), 400, "invalid_input", "robot.urdf");
  std::string deep = "<robot name=\"r\">";
  for (int i = 0; i < 100000; ++i) deep += "<a>";
  expect_error(post(c, with({{"urdf", deep}})), 400, "invalid_input", "robot.urdf");
  std::string wide = "<robot name=\"r\"><link name=\"l\" ";
  for (int i = 0; i < 70000; ++i) {
    wide += 'a';  // (not "a" + std::to_string(i): GCC 12's false -Wrestrict, bug 105329)
    wide += std::to_string(i);
    wide += "=\"\" ";
  }
  expect_error(post(c, with({{"urdf", wide + "/></robot>"}})), 400, "invalid_input", "robot.urdf");
  expect_error(post(c, with({{"urdf", "<robot name=\"r\"><![CDATA[<a><a>]]></robot>"}})), 400, "invalid_input", "robot.urdf");
  expect_error(post(c, with({{"urdf", "<!DOCTYPE r [<!ENTITY x \"y\">]><robot name=\"r\"/>"}})), 400, "invalid_input", "robot.urdf");
  expect_error(post(c, with({{"urdf", "<robot name=r/>"}})), 400, "invalid_input", "robot.urdf");
  expect_error(post(c, with({{"urdf", std::string(robot::kMaxUrdfBytes + 1, ' ')}})), 400, "invalid_input", "robot.urdf");
  expect_error(post(c, with({{"urdf", urdf("cube.obj")}, {"package_dirs", json::object()}})), 400, "invalid_input", "robot.package_dirs");
  expect_error(post(c, with({{"meshes", json::object()}})), 400, "invalid_input", "robot.urdf");
  // Errors past the URDF keep their fields: q against the URDF's one joint.
  json req = with({{"urdf", urdf("cube.obj")}, {"meshes", {{"cube.obj", cube}}}});
  req["q"] = json::array({0.1, 0.2});
  expect_error(post(c, req, s), 400, "invalid_input", "q");
}

TEST_F(RobotApi, BadInputNamesItsField) {
  const json ok = panda_request();
  const auto with = [&](const std::string& key, const json& value) {
    json b = ok;
    b[key] = value;
    return b;
  };
  const auto without = [&](const std::string& key) {
    json b = ok;
    b.erase(key);
    return b;
  };
  expect_error(c.Post("/api/robot/distances", "[1]", "application/json"), 400, "invalid_input", "");
  expect_error(post(c, with("zz", 1)), 400, "invalid_input", "zz");
  expect_error(post(c, without("robot")), 400, "invalid_input", "robot");
  expect_error(post(c, with("robot", 3)), 400, "invalid_input", "robot");
  expect_error(post(c, with("robot", "nope")), 400, "invalid_input", "robot");
  expect_error(post(c, with("robot", "../robots/panda")), 400, "invalid_input", "robot");
  expect_error(post(c, with("robot", {{"zz", 1}})), 400, "invalid_input", "robot.zz");
  expect_error(post(c, without("q")), 400, "invalid_input", "q");
  expect_error(post(c, with("q", json::array())), 400, "invalid_input", "q");
  expect_error(post(c, with("q", {1, 2, 3})), 400, "invalid_input", "q");
  expect_error(post(c, with("q", "0")), 400, "invalid_input", "q");
  json q = ok["q"];
  q[1] = {0, 0, 0};
  expect_error(post(c, with("q", q)), 400, "invalid_input", "q[1]");
  q = ok["q"];
  q[1][2] = "x";
  expect_error(post(c, with("q", q)), 400, "invalid_input", "q[1][2]");
  q[1][2] = 1e300;
  expect_error(post(c, with("q", q)), 400, "invalid_input", "q[1][2]");
  q[1][2] = nullptr;
  expect_error(post(c, with("q", q)), 400, "invalid_input", "q[1][2]");
  // A row's length is checked before its numbers: a first row that is no array makes q one
  // configuration of the wrong length, and a row holding one array is a row of one element.
  q = ok["q"];
  q[0] = "x";
  expect_error(post(c, with("q", q)), 400, "invalid_input", "q");
  q = ok["q"];
  q[1] = json::array({ok["q"][1]});
  expect_error(post(c, with("q", q)), 400, "invalid_input", "q[1]");
  expect_error(post(c, with("obstacles", 1)), 400, "invalid_input", "obstacles");
  json obs = ok["obstacles"];
  obs[1]["size"] = {0.4, -0.4, 0.05};
  expect_error(post(c, with("obstacles", obs)), 400, "invalid_input", "obstacles[1].size[1]");
  obs = ok["obstacles"];
  obs[1].erase("size");
  expect_error(post(c, with("obstacles", obs)), 400, "invalid_input", "obstacles[1].size");
  obs = ok["obstacles"];
  obs[2]["name"] = "wall1";
  expect_error(post(c, with("obstacles", obs)), 400, "invalid_input", "obstacles[2].name");
  obs[2]["name"] = "";
  expect_error(post(c, with("obstacles", obs)), 400, "invalid_input", "obstacles[2].name");
  obs[2]["name"] = 7;
  expect_error(post(c, with("obstacles", obs)), 400, "invalid_input", "obstacles[2].name");
  // An obstacle without a name is "obstacle<i>" (as in Python); a default another one took is
  // refused as a repeated name is.
  obs = ok["obstacles"];
  obs[2].erase("name");
  auto named = post(c, with("obstacles", obs));
  ASSERT_EQ(named->status, 200) << named->body;
  EXPECT_EQ(body_json(named)["pairs"][2]["obstacle"], "obstacle2");
  obs[0]["name"] = "obstacle2";
  expect_error(post(c, with("obstacles", obs)), 400, "invalid_input", "obstacles[2].name");
  obs = ok["obstacles"];
  obs[0]["zz"] = 1;
  expect_error(post(c, with("obstacles", obs)), 400, "invalid_input", "obstacles[0].zz");
  obs = ok["obstacles"];
  obs[0]["type"] = "torus";
  expect_error(post(c, with("obstacles", obs)), 400, "invalid_input", "obstacles[0].type");
  expect_error(post(c, with("metric", "manhattan")), 400, "invalid_input", "metric");
  expect_error(post(c, with("metric", 1)), 400, "invalid_input", "metric");
  expect_error(post(c, with("pairs", "all")), 400, "invalid_input", "pairs");
  expect_error(post(c, with("pairs", {{"zz", true}})), 400, "invalid_input", "pairs.zz");
  expect_error(post(c, with("pairs", {{"self", 1}})), 400, "invalid_input", "pairs.self");
  expect_error(post(c, with("pairs", {{"allow", json::array({json::array({"panda_link1", "panda_link2"})})}})), 400, "invalid_input", "pairs.allow");
  expect_error(post(c, with("pairs", {{"self", true}, {"allow", json::array({json::array({"panda_link1", "nowhere"})})}})), 400, "invalid_input", "pairs.allow[0]");
  expect_error(post(c, with("pairs", {{"self", true}, {"deny", json::array({json::array({"panda_link1"})})}})), 400, "invalid_input", "pairs.deny[0]");
  expect_error(post(c, with("pairs", {{"self", true}, {"deny", json::array({json::array({"panda_link1", 2})})}})), 400, "invalid_input", "pairs.deny[0][1]");
  expect_error(post(c, with("params", {{"tol", -1}})), 400, "invalid_input", "params.tol");
  expect_error(post(c, with("params", {{"zz", 1}})), 400, "invalid_input", "params.zz");
  expect_error(post(c, with("params", {{"solver", "magic"}})), 400, "invalid_input", "params.solver");
  // Property 2 checked on every body in a pair (validate on): a ρ ball that only just covers a
  // box breaks it, as the GAP route says of the same shape; validate false skips the check.
  json tight = box("tight", {0.2, 0.2, 0.2}, {0, 1, 0});
  tight["rho"] = {{"center", {0, 0, 0}}, {"radius", 0.1733}};
  json shape = tight;
  shape.erase("name");
  const json far = {{"type", "sphere"}, {"radius", 0.1}, {"pose", {{"position", {2, 0, 0}}}}};
  const json gap = {{"a", shape}, {"b", far}};
  expect_error(c.Post("/api/gap/distance", gap.dump(), "application/json"), 400, "invalid_input", "a");
  obs = ok["obstacles"];
  obs.push_back(tight);
  expect_error(post(c, with("obstacles", obs)), 400, "invalid_input", "obstacles[3]");
  json unchecked = with("obstacles", obs);
  unchecked["params"] = {{"validate", false}};
  EXPECT_EQ(post(c, unchecked)->status, 200);
  expect_error(post(c, with("comment", 1)), 400, "invalid_input", "comment");
  const json limits = body_json(c.Get("/api/limits"));
  expect_error(post(c, with("params", {{"max_iter", limits["max_gap_iterations"].get<long>() + 1}})), 422, "over_budget", "params.max_iter");
  EXPECT_EQ(post(c, with("comment", "fine"))->status, 200);
}

TEST_F(RobotApi, BuiltInRobotsAreListed) {
  auto r = c.Get("/api/robot/robots");
  ASSERT_EQ(r->status, 200) << r->body;
  const json list = body_json(r)["robots"];
  std::set<std::string> names;
  for (const json& x : list) {
    names.insert(x["name"].get<std::string>());
    const auto rb = robot::Robot::load(std::string(DISTLAB_SOURCE_DIR) + "/assets/robots/" + x["name"].get<std::string>() + ".urdf");
    EXPECT_EQ(x["dof"], rb->dof());
    EXPECT_EQ(x["joint_names"], json(rb->joint_names()));
    EXPECT_EQ(x["links"], json(rb->links()));
    EXPECT_EQ(x["elements"].size(), rb->primitives().size());
    EXPECT_EQ(x["self_pairs"], rb->self_pairs().size());
  }
  EXPECT_TRUE(names.count("panda") && names.count("ur5e"));
  // A listed robot is one the route takes, with its dof.
  json req = {{"robot", "ur5e"}, {"q", std::vector<double>(6, 0.1)}, {"obstacles", json::array({box("b", {0.2, 0.2, 0.2}, {0.5, 0.5, 0.5})})}};
  r = post(c, req);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(body_json(r)["dof"], 6);
}

// Each limit of the table at its boundary: one more configuration, evaluation or obstacle is a
// 413 naming the field; the time limit stops the batch between chunks (408).
TEST(RobotApiLimits, ConfigurationsEvaluationsObstaclesAndTime) {
  ServerProcess server({"--limit", "max_robot_configurations=4", "--limit", "max_robot_pair_evaluations=54", "--limit", "max_robot_obstacles=3"});
  auto c = server.client();
  const json limits = body_json(c.Get("/api/limits"));
  EXPECT_EQ(limits["max_robot_configurations"], 4);
  EXPECT_EQ(limits["max_robot_pair_evaluations"], 54);
  EXPECT_EQ(limits["max_robot_obstacles"], 3);
  EXPECT_EQ(limits["max_urdf_bytes"], robot::kMaxUrdfBytes);
  EXPECT_EQ(limits["request_bounds"]["POST /api/robot/distances"].size(), 7u);
  // The document's bounds are the server's.
  const json request = body_json(c.Get("/api/openapi.json"))["components"]["schemas"]["RobotDistancesRequest"]["properties"];
  EXPECT_EQ(request["q"]["oneOf"][1]["maxItems"], 4);
  EXPECT_EQ(request["obstacles"]["maxItems"], 3);
  json req = panda_request();  // 9 elements × 3 obstacles = 27 pairs
  const json q = req["q"][0];
  req["q"] = {q, q};  // 54 evaluations: at the limit
  EXPECT_EQ(post(c, req)->status, 200);
  req["q"] = {q, q, q};
  expect_error(post(c, req), 413, "too_many_evaluations", "q");
  req["q"] = {q, q, q, q, q};
  expect_error(post(c, req), 413, "too_many_configurations", "q");
  req["q"] = q;
  req["obstacles"].push_back(box("extra", {0.1, 0.1, 0.1}, {0, 1, 0}));
  expect_error(post(c, req), 413, "too_many_obstacles", "obstacles");
  EXPECT_EQ(server.stop(), 0);

  ServerProcess slow({"--max-request-seconds", "0.000001"});
  auto cs = slow.client();
  req = panda_request();
  const auto late = post(cs, req);
  expect_error(late, 408, "time_limit", "");
  // Stopped while its GAP bodies were built, before any configuration (DistanceModel's checkpoint).
  EXPECT_NE(body_json(late)["error"]["message"].get<std::string>().find("collision elements"), std::string::npos) << late->body;
  EXPECT_EQ(cs.Get("/api/health")->status, 200);
  EXPECT_EQ(slow.stop(), 0);
}

// The description limits are entries of the table (GET /api/limits, --limit), and a URDF is held
// to the server's values: at each limit accepted, one past it refused naming robot.urdf.
TEST(RobotApiLimits, DescriptionLimitsAreTheTables) {
  // A chain of `links` links, each with one sphere, joined by revolute joints.
  const auto chain = [](int links) {
    std::string xml = R"(<robot name="r">)";
    for (int i = 0; i < links; ++i) {
      xml += "<link name=\"l" + std::to_string(i) + "\"><collision><geometry><sphere radius=\"0.05\"/></geometry></collision></link>";
      if (i > 0)
        xml += "<joint name=\"j" + std::to_string(i) + "\" type=\"revolute\"><parent link=\"l" + std::to_string(i - 1) +
               "\"/><child link=\"l" + std::to_string(i) + "\"/><origin xyz=\"0 0 0.2\"/><axis xyz=\"0 0 1\"/>" +
               "<limit lower=\"-1\" upper=\"1\" velocity=\"1\" effort=\"1\"/></joint>";
    }
    return xml + "</robot>";
  };
  const std::string two = chain(2), three = chain(3);
  ServerProcess server({"--limit", "max_robot_links=2", "--limit", "max_robot_collision_elements=2", "--limit",
                        "max_urdf_bytes=" + std::to_string(three.size() + 20)});
  auto c = server.client();
  const json limits = body_json(c.Get("/api/limits"));
  EXPECT_EQ(limits["max_robot_links"], 2);
  EXPECT_EQ(limits["max_robot_collision_elements"], 2);
  EXPECT_EQ(limits["max_urdf_bytes"], three.size() + 20);
  EXPECT_EQ(limits["max_robot_joints"], robot::kMaxJoints);
  const auto request = [](const std::string& urdf, int dof) {
    return json{{"robot", {{"urdf", urdf}}}, {"q", std::vector<double>(static_cast<std::size_t>(dof), 0.1)}, {"obstacles", json::array({box("b", {0.2, 0.2, 0.2}, {0.5, 0.5, 0.5})})}};
  };
  auto r = post(c, request(two, 1));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  const std::pair<std::string, std::string> refused[] = {
      {three, "at most 2 links"},
      {three + std::string(21, ' '), "above the limit of " + std::to_string(three.size() + 20)},
  };
  for (const auto& [urdf, what] : refused) {
    r = post(c, request(urdf, 2));
    expect_error(r, 400, "invalid_input", "robot.urdf");
    EXPECT_NE(body_json(r)["error"]["message"].get<std::string>().find(what), std::string::npos) << r->body;
  }
}

}  // namespace
}  // namespace distlab::test
