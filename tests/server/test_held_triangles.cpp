// Big uploads (issue 36, item 5): a mesh over max_object_triangles prepares only simplified (or
// wrapped), and the triangles the server holds in uploads and objects are bounded per client
// address and in all; DELETE gives an upload's back.
#include <chrono>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/surface.hpp"
#include "server/server_fixture.hpp"

namespace distlab::test {
namespace {

constexpr int kSphereFaces = 20480;  // icosphere level 5
constexpr int kObjectTriangles = 5000;

// The unit icosphere at level 5 as a binary STL (three file vertices per triangle).
std::string sphere_stl() {
  const TempDir dir("distlab-held");
  const std::string path = (dir / "sphere.stl").string();
  mesh::save_mesh(mesh::icosphere(1.0, 5), path, "stl");
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

httplib::Result upload(httplib::Client& c, const std::string& s, const std::string& stl) {
  return c.Post("/api/kelvin/uploads?format=stl", session_headers(s), stl, "application/octet-stream");
}

class HeldTriangles : public SharedServerTest<HeldTriangles> {
 public:
  // Room for two spheres and one cube (12 triangles) per client address.
  static std::vector<std::string> server_options() {
    return {"--limit", "max_object_triangles=" + std::to_string(kObjectTriangles), "--limit",
            "max_held_triangles_per_address=" + std::to_string(2 * kSphereFaces + 12), "--limit", "max_vertex_estimate=40000"};
  }

 protected:
  const std::string stl = sphere_stl();
};

TEST_F(HeldTriangles, ABigMeshPreparesOnlySimplifiedToWhatAPreparationTakes) {
  const std::string s = new_session(c);
  auto r = upload(c, s, stl);
  ASSERT_EQ(r->status, 201) << r->body;
  const std::string up = body_json(r)["upload"];
  const auto create = [&](const json& body) { return c.Post("/api/kelvin/objects", session_headers(s), body.dump(), "application/json"); };
  r = create({{"upload", up}, {"lx_fraction", 0.2}});
  ASSERT_EQ(r->status, 422) << r->body;
  EXPECT_EQ(body_json(r)["error"]["code"], "too_many_triangles");
  EXPECT_EQ(body_json(r)["error"]["field"], "simplify.faces");
  EXPECT_NE(r->body.find(std::to_string(kObjectTriangles)), std::string::npos) << r->body;
  r = create({{"upload", up}, {"lx_fraction", 0.2}, {"simplify", {{"faces", kObjectTriangles + 1}}}});
  ASSERT_EQ(r->status, 400) << r->body;
  EXPECT_EQ(body_json(r)["error"]["field"], "simplify.faces");
  r = create({{"upload", up}, {"lx_fraction", 0.2}, {"simplify", {{"faces", kObjectTriangles}}}});
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string id = body_json(r)["object"]["id"];
  json st;
  for (int i = 0; i < 1200 && (st.empty() || st["state"] == "preparing" || st["state"] == "repairing"); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    st = body_json(c.Get("/api/kelvin/objects/" + id, session_headers(s)));
  }
  ASSERT_EQ(st["state"], "ready") << st.dump();
  EXPECT_EQ(st["simplify_report"]["n_input_faces"], kSphereFaces);
  EXPECT_LE(st["simplify_report"]["n_faces"].get<int>(), kObjectTriangles);
  EXPECT_EQ(c.Delete("/api/kelvin/objects/" + id, session_headers(s))->status, 204);
  EXPECT_EQ(c.Delete("/api/kelvin/uploads/" + up, session_headers(s))->status, 204);
}

// Every session of one address shares its share: two spheres fit, a third does not (in any of
// its sessions), until one is deleted; an object holds its input's triangles until it is deleted.
TEST_F(HeldTriangles, OneAddressHoldsAtMostItsShareUntilItDeletes) {
  const std::string s = new_session(c), t = new_session(c);
  auto a = upload(c, s, stl), b = upload(c, s, stl);
  ASSERT_EQ(a->status, 201) << a->body;
  ASSERT_EQ(b->status, 201) << b->body;
  for (const std::string& session : {s, t}) {
    auto r = upload(c, session, stl);
    ASSERT_EQ(r->status, 413) << r->body;
    EXPECT_EQ(body_json(r)["error"]["code"], "too_much_held");
    EXPECT_EQ(body_json(r)["error"]["field"], "body");
  }
  const std::string first = body_json(a)["upload"];
  EXPECT_EQ(c.Delete("/api/kelvin/uploads/" + first, session_headers(s))->status, 204);
  EXPECT_EQ(c.Delete("/api/kelvin/uploads/" + first, session_headers(s))->status, 404);
  EXPECT_EQ(c.Get("/api/kelvin/uploads/" + first + "/surface", session_headers(s))->status, 404);
  auto r = upload(c, t, stl);
  ASSERT_EQ(r->status, 201) << r->body;
  // Two spheres again, and a cube object (12 triangles) in the rest of the share; then a second
  // cube does not fit, refused naming its source.
  const auto cube = [&] { return c.Post("/api/kelvin/objects", session_headers(s), json{{"asset", "cube"}, {"lx", 0.3}}.dump(), "application/json"); };
  r = cube();
  ASSERT_EQ(r->status, 202) << r->body;
  r = cube();
  ASSERT_EQ(r->status, 413) << r->body;
  EXPECT_EQ(body_json(r)["error"]["field"], "asset");
  r = upload(c, t, stl);
  ASSERT_EQ(r->status, 413) << r->body;
  EXPECT_EQ(c.Delete("/api/kelvin/uploads/" + body_json(b)["upload"].get<std::string>(), session_headers(s))->status, 204);
  r = upload(c, t, stl);
  ASSERT_EQ(r->status, 201) << r->body;  // 2 × 20480 + 12 again
  EXPECT_EQ(c.Delete("/api/kelvin/uploads/" + body_json(r)["upload"].get<std::string>(), session_headers(t))->status, 204);
  // Deleting the session gives the rest back.
  EXPECT_EQ(c.Delete("/api/session", session_headers(t))->status, 204);
  EXPECT_EQ(c.Delete("/api/session", session_headers(s))->status, 204);
  // (A session is dropped once its last request or job lets go of it: a few ms.)
  const std::string u = new_session(c);
  int status = 0;
  for (int i = 0; i < 100 && (status = upload(c, u, stl)->status) != 201; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(status, 201);
  EXPECT_EQ(upload(c, u, stl)->status, 201);
  EXPECT_EQ(c.Delete("/api/session", session_headers(u))->status, 204);
}

// The server's own total: 503 busy beyond it, whatever the address.
class HeldTrianglesTotal : public SharedServerTest<HeldTrianglesTotal> {
 public:
  static std::vector<std::string> server_options() { return {"--limit", "max_held_triangles=" + std::to_string(kSphereFaces + 100)}; }

 protected:
  const std::string stl = sphere_stl();
};

TEST_F(HeldTrianglesTotal, BeyondTheServersTotalTheAnswerIsBusy) {
  const std::string s = new_session(c);
  ASSERT_EQ(upload(c, s, stl)->status, 201);
  auto r = upload(c, s, stl);
  ASSERT_EQ(r->status, 503) << r->body;
  EXPECT_EQ(body_json(r)["error"]["code"], "busy");
  const json limits = body_json(c.Get("/api/limits"));
  EXPECT_EQ(limits["max_held_triangles"], kSphereFaces + 100);
  EXPECT_EQ(limits["max_object_triangles"], 200000);
}

}  // namespace
}  // namespace distlab::test
