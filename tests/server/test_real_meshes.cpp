// Real meshes (issue 20): uploads in the user's units with the l_x range that fits, refusals a
// user can act on, and "repair": "fix" | "wrap" on object requests; the corpus test runs every
// STL/OBJ/PLY/OFF/GLB of Debian's assimp-testmodels through upload and object creation.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "distlab/mesh/primitives.hpp"
#include "distlab/server/frames.hpp"
#include "mesh/independent_check.hpp"
#include "server/server_fixture.hpp"

namespace distlab::test {
namespace {

// A 1000 mm cube as OBJ (outward faces), vertices 1-based.
const std::string kCubeMm =
    "v 0 0 0\nv 1000 0 0\nv 1000 1000 0\nv 0 1000 0\nv 0 0 1000\nv 1000 0 1000\nv 1000 1000 1000\nv 0 1000 1000\n"
    "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 3 4 8\nf 3 8 7\nf 2 3 7\nf 2 7 6\nf 1 5 8\nf 1 8 4\n";

constexpr int kBudget = 40000;  // max_vertex_estimate of the test server

class RealMeshes : public SharedServerTest<RealMeshes> {
 public:
  static std::vector<std::string> server_options() {
    return {"--limit", "max_vertex_estimate=" + std::to_string(kBudget), "--limit", "max_uploads_per_session=100"};
  }

 protected:
  std::string s = new_session(c);

  httplib::Result upload(const std::string& bytes, const std::string& query) {
    return c.Post(("/api/kelvin/uploads?" + query), session_headers(s), bytes, "application/octet-stream");
  }
  httplib::Result create(const json& body) {
    return c.Post("/api/kelvin/objects", session_headers(s), body.dump(), "application/json");
  }
  // Polls an object until it leaves repairing/preparing (bounded); returns its status.
  json settle(const std::string& id) {
    json st;
    for (int i = 0; i < 1200; ++i) {  // 120 s
      st = body_json(c.Get(("/api/kelvin/objects/" + id), session_headers(s)));
      if (st["state"] != "preparing" && st["state"] != "repairing") break;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return st;
  }
  void remove(const std::string& id) { c.Delete(("/api/kelvin/objects/" + id), session_headers(s)); }

  // Issue 36: STL exports of a σ sweep, each level including σ's own values on the surface (the
  // object's surface, a painted region's level), checked by the tests' own weld and edge count
  // and by the check the server sends. Returns "passed/exported".
  std::string export_sweep(const std::string& id, const json& box) {
    std::vector<double> lo = box["min"], hi = box["max"];
    const json brush = {{"center", json(lo)}, {"radius", 0.6 * box["diagonal"].get<double>()}, {"value", -0.3}};
    const std::vector<std::pair<json, std::vector<double>>> sweep = {
        {{{"constant", 0.0}}, {0.0, 1e-3, 0.2}},
        {{{"constant", 0.2}}, {0.2, 0.5}},
        {{{"brushes", {brush}}}, {-0.3, 0.0, 0.1}},  // σ = −0.3 in the ball, 0 outside
    };
    int passed = 0, exported = 0;
    for (const auto& [sigma, levels] : sweep) {
      auto r = c.Put(("/api/kelvin/objects/" + id + "/sigma"), session_headers(s), sigma.dump(), "application/json");
      EXPECT_TRUE(r && r->status == 200) << sigma.dump();
      for (const double level : levels) {
        SCOPED_TRACE("sigma " + sigma.dump() + ", level " + std::to_string(level));
        r = c.Get(("/api/kelvin/objects/" + id + "/export?format=stl&level=" + json(level).dump()), session_headers(s));
        if (!r || r->status == 422) {  // a level the field never takes (refusals of a bad surface: below)
          EXPECT_TRUE(r && body_json(r)["error"]["code"] == "empty_isosurface") << (r ? r->body : "no answer");
          continue;
        }
        ++exported;
        EXPECT_EQ(r->status, 200) << r->body;
        const test::Count count = test::count(test::read_binary_stl(r->body));
        const json check = json::parse(r->get_header_value("X-Distlab-Surface-Check"));
        EXPECT_EQ(count.bad_edges, 0);
        EXPECT_EQ(count.pinched, 0);
        EXPECT_EQ(count.collapsed, 0);
        EXPECT_EQ(check["manifold"], true);
        EXPECT_EQ(check["components"], count.components);
        passed += count.bad_edges == 0 && count.pinched == 0 && count.collapsed == 0;
      }
    }
    return std::to_string(passed) + "/" + std::to_string(exported);
  }
};

// The process's peak resident memory (VmHWM) since its last reset, MB.
double peak_megabytes(pid_t pid) {
  std::ifstream in(fs::path("/proc") / std::to_string(pid) / "status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0;
}

void expect_no_server_path(const std::string& message, const std::string& cache_dir) {
  EXPECT_EQ(message.find(cache_dir), std::string::npos) << message;
  EXPECT_EQ(message.find("upload-"), std::string::npos) << message;
  EXPECT_EQ(message.find("/dev/fd"), std::string::npos) << message;
  EXPECT_EQ(message.find("/tmp"), std::string::npos) << message;
}

// The upload's answer: the box in metres after the unit, and the l_x range whose ends are the
// budget's l_x (the estimate solved for l_x) and the diagonal.
TEST_F(RealMeshes, UnitsScaleTheBoxAndTheLxRangeFitsTheBudget) {
  for (const auto& [params, metres] : std::vector<std::pair<std::string, double>>{
           {"format=obj&unit=mm", 1.0}, {"format=obj&scale=0.001", 1.0}, {"format=obj&unit=cm", 10.0}, {"format=obj", 1000.0}}) {
    SCOPED_TRACE(params);
    auto r = upload(kCubeMm, params);
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 201) << r->body;
    const json a = body_json(r);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(a["bounding_box"]["max"][k].get<double>(), metres, 1e-12 * metres);
    EXPECT_NEAR(a["bounding_box"]["diagonal"].get<double>(), std::sqrt(3.0) * metres, 1e-9 * metres);
    // 20 (r / l_x)³ + 8 = kBudget at r = diagonal / 2.
    const double expected = std::sqrt(3.0) * metres / 2 * std::cbrt(20.0 / (kBudget - 8));
    if (a["lx_range"].is_null()) continue;
    EXPECT_NEAR(a["lx_range"]["min"].get<double>(), std::max(expected, 0.005), 1e-6 * metres);
    EXPECT_NEAR(a["lx_range"]["max"].get<double>(), 0.5 * metres, 1e-9 * metres);  // half the largest extent
    EXPECT_NEAR(a["lx_fraction_range"]["min"].get<double>() * a["bounding_box"]["diagonal"].get<double>(),
                a["lx_range"]["min"].get<double>(), 1e-9 * metres);
  }
  for (const char* const bad : {"format=obj&unit=furlong", "format=obj&scale=-1", "format=obj&scale=0", "format=obj&unit=mm&scale=0.001"}) {
    auto r = upload(kCubeMm, std::string(bad));
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 400) << bad;
    const std::string field = body_json(r)["error"]["field"];
    EXPECT_TRUE(field == "unit" || field == "scale") << bad << ": " << r->body;
  }
}

// lx_fraction is of the diagonal; an over-budget l_x is refused naming the l_x that fits, and
// that l_x is accepted.
TEST_F(RealMeshes, LxFractionAndTheOverBudgetRefusalNamesTheLxThatFits) {
  const json a = body_json(upload(kCubeMm, "format=obj&unit=mm"));
  const std::string up = a["upload"];
  const double lx_min = a["lx_range"]["min"];
  auto r = create({{"upload", up}, {"lx_fraction", 0.5}});
  ASSERT_EQ(r->status, 202) << r->body;
  const json o = body_json(r)["object"];
  EXPECT_NEAR(o["source"]["lx"].get<double>(), 0.5 * std::sqrt(3.0), 1e-12);
  remove(o["id"]);
  // lx_range's min is the closed form's (kelvin_json.hpp, count_vertices): a little finer, the prediction
  // accepts; at 0.45 of it (the cube's ~300k predicted, 1.5 × that over 320k) it refuses.
  r = create({{"upload", up}, {"lx", lx_min * 0.9}});
  EXPECT_EQ(r->status, 202) << r->body;
  if (r->status == 202) remove(body_json(r)["object"]["id"]);
  r = create({{"upload", up}, {"lx", lx_min * 0.45}});
  ASSERT_EQ(r->status, 422) << r->body;
  const std::string message = body_json(r)["error"]["message"];
  EXPECT_NE(message.find("lx " + json(lx_min).dump() + " m or larger fits"), std::string::npos) << message;
  r = create({{"upload", up}, {"lx", lx_min}});
  EXPECT_EQ(r->status, 202) << r->body;
  if (r->status == 202) remove(body_json(r)["object"]["id"]);
  for (const json& bad : {json{{"upload", up}, {"lx_fraction", 0}}, json{{"upload", up}, {"lx_fraction", 1.5}},
                          json{{"upload", up}, {"lx", 0.5}, {"lx_fraction", 0.5}}, json{{"upload", up}}}) {
    r = create(bad);
    EXPECT_EQ(r->status, 400) << bad.dump() << ": " << r->body;
  }
}

// Refusals that say what is wrong with the file, and a UTF-16 OBJ read as the text it is.
TEST_F(RealMeshes, RefusalsNameTheProblem) {
  const auto refused = [&](const std::string& bytes, const std::string& format, const std::string& says) {
    auto r = upload(bytes, "format=" + format);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 400) << r->body;
    const std::string message = body_json(r)["error"]["message"];
    EXPECT_NE(message.find(says), std::string::npos) << message;
    expect_no_server_path(message, server_->cache_dir());
  };
  refused("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "obj", "no faces: a point cloud");
  refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n", "obj", "no faces");
  refused("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n",
          "ply", "no faces: a point cloud");
  refused("", "off", "empty");
  std::string glb1 = std::string("glTF") + std::string("\x01\0\0\0", 4) + std::string("\x14\0\0\0", 4) + std::string(8, '\0');
  refused(glb1, "glb", "glTF version 1");
  // A binary STL tetrahedron with one NaN coordinate (BoxWithInfinites.glb's case).
  std::string stl(80, '\0');
  const std::uint32_t n = 4;
  stl.append(reinterpret_cast<const char*>(&n), 4);
  const float nan = std::nanf(""), corners[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const int tets[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (const auto& t : tets) {
    stl.append(12, '\0');
    for (int k : t)
      for (int d = 0; d < 3; ++d) {
        const float x = (k == 3 && d == 0) ? nan : corners[k][d];
        stl.append(reinterpret_cast<const char*>(&x), 4);
      }
    stl.append(2, '\0');
  }
  refused(stl, "stl", "non-finite");

  // UTF-16 LE with a byte-order mark: the same cube as the ASCII file.
  std::string utf16 = "\xFF\xFE";
  for (char ch : kCubeMm) utf16 += std::string{ch, '\0'};
  auto r = upload(utf16, "format=obj&unit=mm");
  ASSERT_EQ(r->status, 201) << r->body;
  EXPECT_EQ(body_json(r)["n_vertices"], 8);
  EXPECT_EQ(body_json(r)["n_faces"], 12);

  // Not closed, and an unused first vertex, so that the weld numbers vertices one below the
  // file: the message numbers them as the file does. The missing face is the file's (1, 8, 4)
  // (0-based), so the first boundary edge is (1, 4).
  std::string open = "v 9 9 9\n";
  std::istringstream lines(kCubeMm);
  for (std::string line; std::getline(lines, line);) {
    if (line == "f 1 8 4") continue;
    if (line[0] == 'v') {
      open += line + "\n";
      continue;
    }
    std::istringstream in(line.substr(2));
    int i, j, k;
    in >> i >> j >> k;
    open += "f " + std::to_string(i + 1) + " " + std::to_string(j + 1) + " " + std::to_string(k + 1) + "\n";
  }
  r = upload(open, "format=obj&unit=mm");
  ASSERT_EQ(r->status, 201) << r->body;
  r = create({{"upload", body_json(r)["upload"]}, {"lx_fraction", 0.5}});
  ASSERT_EQ(r->status, 400) << r->body;
  const std::string message = body_json(r)["error"]["message"];
  EXPECT_NE(message.find("3 boundary edges"), std::string::npos) << message;
  EXPECT_NE(message.find("first at edge (1, 4)"), std::string::npos) << message;
  EXPECT_NE(message.find("\"fix\""), std::string::npos) << message;
}

// An open box is fixed (the hole filled) and a sphere-like soup is wrapped, as jobs; the
// answers report the steps and the distances.
TEST_F(RealMeshes, FixAndWrapAreJobsWithReports) {
  const std::string open = kCubeMm.substr(0, kCubeMm.rfind("f 1 8 4\n"));
  const std::string up = body_json(upload(open, "format=obj&unit=mm"))["upload"];
  auto r = create({{"upload", up}, {"lx_fraction", 0.5}, {"repair", "fix"}, {"repair_options", {{"max_hole_edges", 3}}}});
  ASSERT_EQ(r->status, 202) << r->body;
  json st = settle(body_json(r)["object"]["id"]);
  ASSERT_EQ(st["state"], "ready") << st.dump();
  EXPECT_EQ(st["repair_report"]["steps"]["filled_holes"], 1) << st.dump();
  EXPECT_EQ(st["repair_report"]["n_faces"], 12);
  remove(st["id"]);

  r = create({{"upload", up}, {"lx_fraction", 0.5}, {"repair", "fix"}});
  ASSERT_EQ(r->status, 202) << r->body;
  st = settle(body_json(r)["object"]["id"]);
  EXPECT_EQ(st["state"], "failed") << st.dump();
  EXPECT_NE(st["error"]["message"].get<std::string>().find("boundary edge"), std::string::npos) << st.dump();
  remove(st["id"]);

  r = create({{"upload", up}, {"lx_fraction", 0.5}, {"repair", "wrap"}, {"repair_options", {{"alpha", 0.3}, {"offset", 0.01}}}});
  ASSERT_EQ(r->status, 202) << r->body;
  st = settle(body_json(r)["object"]["id"]);
  ASSERT_EQ(st["state"], "ready") << st.dump();
  EXPECT_EQ(st["repair_report"]["alpha"], 0.3);
  EXPECT_LT(st["repair_report"]["hausdorff"]["input_to_wrap"].get<double>(), 0.3);
  EXPECT_LT(st["repair_report"]["hausdorff"]["wrap_to_input"].get<double>(), 0.3);
  remove(st["id"]);

  for (const json& bad : {json{{"repair", "melt"}}, json{{"repair", "wrap"}, {"repair_options", {{"alpha", -1}}}},
                          json{{"repair", "fix"}, {"repair_options", {{"alpha", 1}}}}, json{{"repair_options", {{"alpha", 1}}}},
                          json{{"repair", "fix"}, {"repair_options", {{"max_hole_edges", 1e9}}}}}) {
    json body = bad;
    body["upload"] = up;
    body["lx_fraction"] = 0.5;
    r = create(body);
    EXPECT_EQ(r->status, 400) << body.dump() << ": " << r->body;
    EXPECT_EQ(body_json(r)["error"]["field"].get<std::string>().rfind("repair", 0), 0u) << r->body;
  }
}

// A long wrap (the open unit sphere at α 0.02: about 120k faces expected) reports stage "repair"
// from inside CGAL's flood fill; cancelled there, its job ends "cancelled" having made little more
// progress (fraction below 0.8, where the flood fill ends) and the object has no repaired surface.
TEST_F(RealMeshes, ALongWrapIsCancelledInsideTheFloodFill) {
  const mesh::SurfaceMesh sphere = mesh::icosphere(1.0, 4);
  json vertices = json::array(), faces = json::array();
  for (Eigen::Index v = 0; v < sphere.vertices.rows(); ++v) vertices.push_back({sphere.vertices(v, 0), sphere.vertices(v, 1), sphere.vertices(v, 2)});
  for (Eigen::Index f = 0; f < sphere.faces.rows(); ++f)
    if (sphere.vertices(sphere.faces(f, 0), 2) <= 0.8) faces.push_back({sphere.faces(f, 0), sphere.faces(f, 1), sphere.faces(f, 2)});
  auto r = create({{"mesh", {{"vertices", vertices}, {"faces", faces}}}, {"lx_fraction", 0.2}, {"repair", "wrap"}, {"repair_options", {{"alpha", 0.02}, {"offset", 0.002}}}});
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string id = body_json(r)["object"]["id"], job = body_json(r)["job"]["id"];
  const auto job_status = [&] { return body_json(c.Get(("/api/jobs/" + job), session_headers(s))); };
  json st;
  for (int i = 0; i < 2400; ++i) {  // until the wrap has reported from inside the flood fill
    st = job_status();
    if (st["state"] != "queued" && st["state"] != "running") break;
    if (st["stage"] == "repair" && st["fraction"].get<double>() > 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  ASSERT_EQ(st["state"], "running") << st.dump();
  ASSERT_EQ(st["stage"], "repair") << st.dump();
  const double at_cancel = st["fraction"];
  ASSERT_GT(at_cancel, 0.0);
  ASSERT_LT(at_cancel, 0.8) << "the flood fill ended before the test saw it";
  r = c.Post(("/api/jobs/" + job + "/cancel"), session_headers(s), "", "application/json");
  ASSERT_TRUE(r);
  ASSERT_LT(r->status, 300) << r->body;
  for (int i = 0; i < 2400; ++i) {
    st = job_status();
    if (st["state"] != "queued" && st["state"] != "running") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  std::printf("cancelled at fraction %.3f, stopped at %.3f\n", at_cancel, st["fraction"].get<double>());
  EXPECT_EQ(st["state"], "cancelled") << st.dump();
  EXPECT_EQ(st["error"]["code"], "cancelled") << st.dump();
  EXPECT_EQ(st["stage"], "repair");
  EXPECT_LT(st["fraction"].get<double>(), 0.8);  // stopped inside the flood fill
  const json o = settle(id);
  EXPECT_EQ(o["state"], "cancelled") << o.dump();
  EXPECT_FALSE(o.contains("repair_report") && !o["repair_report"].is_null()) << o.dump();
  r = c.Get(("/api/kelvin/objects/" + id + "/surface?of=repaired"), session_headers(s));
  EXPECT_EQ(r->status, 409) << r->body;
  r = c.Get(("/api/kelvin/objects/" + id + "/surface"), session_headers(s));  // the input, σ as given
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  remove(id);
}

// σ = z / 2 per file vertex of the unit sphere with a hole (radius 0.6), wrapped at α 0.8 (so the
// wrap closes the hole and is a ball, not a shell around both sides): the field's σ at the wrap's
// vertices (surface?of=repaired) and read back at the file's vertices (surface) reproduce the
// closed form within the wrap's distances (barycentric interpolation is exact for linear σ, so
// only the distance to the nearest face shows; |∂σ/∂z| = 1/2).
TEST_F(RealMeshes, SigmaPerVertexRoundTripsThroughTheWrap) {
  const mesh::SurfaceMesh sphere = mesh::icosphere(1.0, 3);
  json vertices = json::array(), faces = json::array(), sigma = json::array();
  for (Eigen::Index v = 0; v < sphere.vertices.rows(); ++v) {
    vertices.push_back({sphere.vertices(v, 0), sphere.vertices(v, 1), sphere.vertices(v, 2)});
    sigma.push_back(0.5 * sphere.vertices(v, 2));
  }
  for (Eigen::Index f = 0; f < sphere.faces.rows(); ++f) {
    const double z = (sphere.vertices(sphere.faces(f, 0), 2) + sphere.vertices(sphere.faces(f, 1), 2) + sphere.vertices(sphere.faces(f, 2), 2)) / 3;
    if (z <= 0.8) faces.push_back({sphere.faces(f, 0), sphere.faces(f, 1), sphere.faces(f, 2)});
  }
  auto r = create({{"mesh", {{"vertices", vertices}, {"faces", faces}}}, {"lx_fraction", 0.2}, {"repair", "wrap"}, {"repair_options", {{"alpha", 0.8}, {"offset", 0.02}}}, {"sigma", {{"per_vertex", sigma}}}});
  ASSERT_EQ(r->status, 202) << r->body;
  const json st = settle(body_json(r)["object"]["id"]);
  ASSERT_EQ(st["state"], "ready") << st.dump();
  const double in_to_wrap = st["repair_report"]["hausdorff"]["input_to_wrap"];
  const double wrap_to_in = st["repair_report"]["hausdorff"]["wrap_to_input"];
  const std::string id = st["id"];
  auto frame = json::from_msgpack(c.Get(("/api/kelvin/objects/" + id + "/surface?of=repaired"), session_headers(s))->body);
  auto pos = server::read_float32(frame["positions"]);
  auto values = server::read_float32(frame["scalars"]);
  ASSERT_EQ(pos.size(), 3 * values.size());
  double worst = 0;
  for (std::size_t j = 0; j < values.size(); ++j) worst = std::max(worst, std::abs(values[j] - 0.5 * pos[3 * j + 2]));
  std::printf("wrap (%zu vertices): max |σ − z/2| %.4f (bound %.4f)\n", values.size(), worst, 0.5 * wrap_to_in);
  EXPECT_LE(worst, 0.5 * wrap_to_in + 1e-5);  // float32 frames
  frame = json::from_msgpack(c.Get(("/api/kelvin/objects/" + id + "/surface"), session_headers(s))->body);
  pos = server::read_float32(frame["positions"]);
  values = server::read_float32(frame["scalars"]);
  ASSERT_EQ(values.size(), static_cast<std::size_t>(sphere.vertices.rows()));
  std::vector<bool> used(values.size(), false);  // the cap's vertices are in no face: not surface
  for (const json& f : faces)
    for (const json& v : f) used[v.get<std::size_t>()] = true;
  worst = 0;
  for (std::size_t i = 0; i < values.size(); ++i)
    if (used[i]) worst = std::max(worst, std::abs(values[i] - 0.5 * sphere.vertices(static_cast<Eigen::Index>(i), 2)));
  std::printf("file vertices: max |σ − z/2| %.4f (bound %.4f)\n", worst, 0.5 * (in_to_wrap + wrap_to_in));
  EXPECT_LE(worst, 0.5 * (in_to_wrap + wrap_to_in) + 1e-5);
  EXPECT_LT(worst, 0.1);
  remove(id);
}

// Every STL/OBJ/PLY/OFF/GLB file of assimp-testmodels: uploaded (in its own unit: metres), then an
// object at a coarse l_x; not closed → "fix", then "wrap". None may kill the server; each is
// prepared or refused with a message; the table is printed.
TEST_F(RealMeshes, TheAssimpCorpusIsPreparedOrRefusedByName) {
  const fs::path root = "/usr/share/assimp/models";
  if (!fs::is_directory(root)) GTEST_SKIP() << "assimp-testmodels is not installed (.ci/packages.txt)";
  std::vector<fs::path> files;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    if (e.is_regular_file() && (ext == ".stl" || ext == ".obj" || ext == ".ply" || ext == ".off" || ext == ".glb")) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  ASSERT_GT(files.size(), 40u);
  std::map<std::string, int> tally;
  std::printf("| file | bytes | outcome | s | server peak MB | exports closed | detail |\n|---|---|---|---|---|---|---|\n");
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    std::ifstream in(file, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), {});
    std::string format = file.extension().string().substr(1);
    std::transform(format.begin(), format.end(), format.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    std::string outcome, detail, exports;
    // The note's table: the server's peak memory over this file (its peak reset first) and the
    // seconds from upload to a settled object. Printed, never asserted.
    std::ofstream(fs::path("/proc") / std::to_string(server_->pid()) / "clear_refs") << "5";
    const auto start = std::chrono::steady_clock::now();
    auto r = upload(bytes, "format=" + format);
    ASSERT_TRUE(r) << "no answer: the server died";
    if (r->status == 400 && body_json(r)["error"]["message"].get<std::string>().find("unit=mm") != std::string::npos) {
      r = upload(bytes, "format=" + format + "&unit=mm");  // as the refusal suggests
      ASSERT_TRUE(r) << "no answer: the server died";
    }
    if (r->status != 201) {
      outcome = "refused at upload";
      detail = body_json(r)["error"]["message"];
    } else if (body_json(r)["lx_range"].is_null()) {
      outcome = "refused: no l_x fits";
      detail = std::to_string(body_json(r)["n_vertices"].get<long>()) + " vertices";
    } else {
      const json a = body_json(r);
      const double fraction = std::min(a["lx_fraction_range"]["max"].get<double>(), std::max(0.25, a["lx_fraction_range"]["min"].get<double>()));
      for (const std::string& repair : std::vector<std::string>{"none", "fix", "wrap"}) {
        json body = {{"upload", a["upload"]}, {"lx_fraction", fraction}, {"repair", repair}};
        if (repair == "fix") body["repair_options"] = {{"max_hole_edges", 50}};
        r = create(body);
        ASSERT_TRUE(r) << "no answer: the server died";
        if (r->status != 202) {
          outcome = "refused (" + repair + ")";
          detail = body_json(r)["error"]["message"];
          if (r->status == 400 && repair != "wrap") continue;  // not closed: try the next repair
          break;
        }
        const json st = settle(body_json(r)["object"]["id"]);
        if (st["state"] == "ready") {
          outcome = "prepared (" + repair + ")";
          detail = st.contains("repair_report") ? st["repair_report"].dump() : "";
          exports = export_sweep(st["id"], a["bounding_box"]);
          remove(st["id"]);
          break;
        }
        remove(st["id"]);
        outcome = "failed (" + repair + ")";
        detail = st["error"]["message"];
        ASSERT_NE(st["state"], "preparing") << "not settled in 120 s";
      }
    }
    EXPECT_FALSE(detail.empty() && outcome.rfind("prepared", 0) != 0) << outcome;
    expect_no_server_path(detail, server_->cache_dir());
    tally[outcome.substr(0, outcome.find(' '))]++;
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("| %s | %zu | %s | %.1f | %.0f | %s | %s |\n", fs::relative(file, root).c_str(), bytes.size(), outcome.c_str(), seconds,
                peak_megabytes(server_->pid()), exports.c_str(), detail.substr(0, 160).c_str());
    auto h = c.Get("/api/health");
    ASSERT_TRUE(h) << "the server died after " << file;
  }
  for (const auto& [k, n] : tally) std::printf("%s: %d\n", k.c_str(), n);
  // No upload ever lands in the cache directory (uploads are anonymous in-memory files).
  for (const auto& e : fs::recursive_directory_iterator(server_->cache_dir()))
    EXPECT_EQ(e.path().filename().string().rfind("upload-", 0), std::string::npos) << e.path();
}

}  // namespace
}  // namespace distlab::test
