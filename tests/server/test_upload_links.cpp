// Uploads a link can name and defects a page can draw (issue 37, items 1 and 2): an upload's
// digest is the SHA-256 of its mesh as read (unit included, file format not); another session
// reuses a held mesh by its digest and learns nothing else; a re-upload is checked against the
// digest; GET .../defects gives the defects where the file has them, in its own numbering; a fix
// reports how far it moved the surface.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "distlab/kelvin/digest.hpp"
#include "distlab/mesh/hausdorff.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/server/frames.hpp"
#include "server/server_fixture.hpp"

namespace distlab::test {
namespace {

class UploadLinks : public SharedServerTest<UploadLinks> {
 protected:
  httplib::Result upload(const std::string& s, const std::string& bytes, const std::string& query) {
    return c.Post("/api/kelvin/uploads?" + query, session_headers(s), bytes, "application/octet-stream");
  }
  httplib::Result reuse(const std::string& s, const json& body) {
    return c.Post("/api/kelvin/uploads/reuse", session_headers(s), body.dump(), "application/json");
  }
};

// A mesh as OBJ text (1-based faces), or as OFF.
std::string obj_text(const mesh::SurfaceMesh& m) {
  std::ostringstream out;
  out.precision(17);
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) out << "v " << m.vertices(v, 0) << ' ' << m.vertices(v, 1) << ' ' << m.vertices(v, 2) << '\n';
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) out << "f " << m.faces(f, 0) + 1 << ' ' << m.faces(f, 1) + 1 << ' ' << m.faces(f, 2) + 1 << '\n';
  return out.str();
}
std::string off_text(const mesh::SurfaceMesh& m) {
  std::ostringstream out;
  out.precision(17);
  out << "OFF\n";
  out << m.vertices.rows() << ' ' << m.faces.rows() << " 0\n";
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) out << m.vertices(v, 0) << ' ' << m.vertices(v, 1) << ' ' << m.vertices(v, 2) << '\n';
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) out << "3 " << m.faces(f, 0) << ' ' << m.faces(f, 1) << ' ' << m.faces(f, 2) << '\n';
  return out.str();
}

// The box of side s without face `skip` (a hole of three edges).
mesh::SurfaceMesh open_box(double s, Eigen::Index skip) {
  mesh::SurfaceMesh m = mesh::box(Vec3(s, s, s));
  m.faces.row(skip) = m.faces.row(m.faces.rows() - 1);
  m.faces.conservativeResize(m.faces.rows() - 1, 3);
  return m;
}

// The documented digest, computed here: SHA-256 of the vertex and face counts (int64), the
// vertices (float64, row by row) and the faces (int32).
std::string documented_digest(const mesh::SurfaceMesh& m) {
  kelvin::Sha256 h;
  const std::int64_t rows[2] = {m.vertices.rows(), m.faces.rows()};
  h.add(rows, sizeof rows);
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v)
    for (int k = 0; k < 3; ++k) h.add(&m.vertices(v, k), sizeof(double));
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) h.add(&m.faces(f, k), sizeof(int));
  return h.hex();
}

TEST_F(UploadLinks, TheDigestIsTheMeshAsRead) {
  const std::string s = new_session(c);
  const mesh::SurfaceMesh cube = mesh::box(Vec3(1, 1, 1));
  const json obj = body_json(upload(s, obj_text(cube), "format=obj"));
  ASSERT_TRUE(obj.contains("digest")) << obj.dump();
  EXPECT_EQ(obj["digest"], documented_digest(cube));
  EXPECT_EQ(obj["bytes"], obj_text(cube).size());
  EXPECT_EQ(obj["format"], "obj");
  // The same mesh in another format is the same mesh; in millimetres, or one vertex moved, not.
  EXPECT_EQ(body_json(upload(s, off_text(cube), "format=off"))["digest"], obj["digest"]);
  mesh::SurfaceMesh mm = cube;
  mm.vertices *= 0.001;
  const json in_mm = body_json(upload(s, obj_text(cube), "format=obj&unit=mm"));
  EXPECT_EQ(in_mm["digest"], documented_digest(mm));
  EXPECT_NE(in_mm["digest"], obj["digest"]);
  mesh::SurfaceMesh moved = cube;
  moved.vertices(3, 0) += 0.25;
  EXPECT_NE(body_json(upload(s, obj_text(moved), "format=obj"))["digest"], obj["digest"]);
  // An object made from the upload reports the digest as its surface_digest.
  auto r = c.Post("/api/kelvin/estimate", session_headers(s), json{{"upload", obj["upload"]}, {"lx", 0.3}}.dump(), "application/json");
  ASSERT_EQ(r->status, 200) << r->body;
  r = c.Post("/api/kelvin/objects", session_headers(s), json{{"upload", obj["upload"]}, {"lx", 0.3}}.dump(), "application/json");
  ASSERT_EQ(r->status, 202) << r->body;
  EXPECT_EQ(body_json(r)["object"]["surface_digest"], obj["digest"]);
}

// Another session reuses the held mesh by its digest: a new upload id of its own, the same mesh,
// nothing of the first session; once no session holds it, the server no longer does either.
TEST_F(UploadLinks, AnotherSessionReusesAHeldMeshByDigestOnly) {
  const std::string a = new_session(c), b = new_session(c), third = new_session(c);
  const mesh::SurfaceMesh m = mesh::icosphere(0.5, 2);
  const json mine = body_json(upload(a, obj_text(m), "format=obj&unit=cm"));
  auto r = reuse(b, {{"digest", mine["digest"]}});
  ASSERT_EQ(r->status, 201) << r->body;
  const json theirs = body_json(r);
  EXPECT_NE(theirs["upload"], mine["upload"]);
  EXPECT_EQ(theirs["reused"], true);
  for (const char* k : {"digest", "n_vertices", "n_faces", "bytes", "format", "unit", "scale", "bounding_box", "lx_range"}) EXPECT_EQ(theirs[k], mine[k]) << k;
  // The same vertices, in the file's order, through b's own id; a's id is not b's.
  r = c.Get("/api/kelvin/uploads/" + theirs["upload"].get<std::string>() + "/surface", session_headers(b));
  ASSERT_EQ(r->status, 200) << r->body;
  const json frame = json::from_msgpack(r->body);
  EXPECT_EQ(frame["digest"], mine["digest"]);
  const std::vector<float> positions = server::read_float32(frame["positions"]);
  ASSERT_EQ(positions.size(), static_cast<std::size_t>(3 * m.vertices.rows()));
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(positions[static_cast<std::size_t>(3 * v + k)], static_cast<float>(m.vertices(v, k) * 0.01));
  r = c.Get("/api/kelvin/uploads/" + mine["upload"].get<std::string>() + "/surface", session_headers(b));
  EXPECT_EQ(r->status, 404) << r->body;
  EXPECT_EQ(get_json(c, b, "/api/session")["uploads"], 1);

  // Absent and malformed digests.
  r = reuse(b, {{"digest", std::string(64, '0')}});
  EXPECT_EQ(r->status, 404) << r->body;
  EXPECT_EQ(body_json(r)["error"]["code"], "upload_not_held");
  EXPECT_EQ(body_json(r)["error"]["field"], "digest");
  for (const json& bad : {json{{"digest", "abc"}}, json{{"digest", std::string(64, 'A')}}, json{{"digest", 7}}, json::object(), json{{"digest", mine["digest"]}, {"name", "x"}}}) {
    r = reuse(b, bad);
    EXPECT_EQ(r->status, 400) << bad.dump() << ": " << r->body;
  }

  // Held while some session holds it.
  ASSERT_EQ(c.Delete("/api/session", session_headers(a))->status, 204);
  EXPECT_EQ(reuse(third, {{"digest", mine["digest"]}})->status, 201);
  ASSERT_EQ(c.Delete("/api/session", session_headers(b))->status, 204);
  ASSERT_EQ(c.Delete("/api/session", session_headers(third))->status, 204);
  const std::string fourth = new_session(c);
  EXPECT_EQ(reuse(fourth, {{"digest", mine["digest"]}})->status, 404);
}

// A link's file given again: refused (and not kept) unless its mesh has the link's digest.
TEST_F(UploadLinks, AnUploadWithAnExpectedDigestIsChecked) {
  const std::string s = new_session(c);
  const mesh::SurfaceMesh cube = mesh::box(Vec3(1, 1, 1));
  const std::string expected = documented_digest(cube);
  auto r = upload(s, obj_text(mesh::box(Vec3(1, 1, 2))), "format=obj&digest=" + expected);
  ASSERT_EQ(r->status, 422) << r->body;
  EXPECT_EQ(body_json(r)["error"]["code"], "different_mesh");
  EXPECT_EQ(body_json(r)["error"]["field"], "body");
  EXPECT_NE(body_json(r)["error"]["message"].get<std::string>().find(expected), std::string::npos);
  // The right file in the wrong unit is another mesh too.
  EXPECT_EQ(upload(s, obj_text(cube), "format=obj&unit=mm&digest=" + expected)->status, 422);
  EXPECT_EQ(get_json(c, s, "/api/session")["uploads"], 0);
  r = upload(s, obj_text(cube), "format=obj&digest=" + expected);
  ASSERT_EQ(r->status, 201) << r->body;
  EXPECT_EQ(body_json(r)["digest"], expected);
  EXPECT_EQ(upload(s, obj_text(cube), "format=obj&digest=xyz")->status, 400);
}

// A box with a missing face and a fin on one of its edges: the hole's three edges and the fin's
// two free ones are open, the fin's edge is in three faces; all named by the file's vertices.
TEST_F(UploadLinks, DefectsAreWhereTheFileHasThem) {
  const std::string s = new_session(c);
  mesh::SurfaceMesh m = open_box(1.0, 0);  // the hole: box face 0's edges
  const mesh::SurfaceMesh whole = mesh::box(Vec3(1, 1, 1));
  // The fin on box edge (4, 5), which box face 0 (0, 2, 1) does not touch.
  m.vertices.conservativeResize(9, 3);
  m.vertices.row(8) << 0, 2, 0.5;
  m.faces.conservativeResize(m.faces.rows() + 1, 3);
  m.faces.row(m.faces.rows() - 1) << 4, 5, 8;
  const json up = body_json(upload(s, obj_text(m), "format=obj"));
  ASSERT_TRUE(up.contains("upload")) << up.dump();
  const json d = get_json(c, s, "/api/kelvin/uploads/" + up["upload"].get<std::string>() + "/defects");
  EXPECT_EQ(d["counts"]["boundary_edges"], 5) << d.dump();
  EXPECT_EQ(d["counts"]["non_manifold_edges"], 1) << d.dump();
  EXPECT_EQ(d["counts"]["components"], 1) << d.dump();
  std::vector<std::array<int, 2>> open;
  for (int k = 0; k < 3; ++k) {
    const int a = whole.faces(0, k), b = whole.faces(0, (k + 1) % 3);
    open.push_back({std::min(a, b), std::max(a, b)});
  }
  open.push_back({4, 8});
  open.push_back({5, 8});
  std::sort(open.begin(), open.end());
  using Pairs = std::vector<std::array<int, 2>>;
  EXPECT_EQ(d["boundary_edges"].get<Pairs>(), open);
  EXPECT_EQ(d["non_manifold_edges"].get<Pairs>(), (Pairs{{4, 5}}));
  EXPECT_EQ(d["max_items"], body_json(c.Get("/api/limits"))["max_defect_items"]);
  EXPECT_FALSE(d["truncated"].get<bool>());
  EXPECT_EQ(c.Get("/api/kelvin/uploads/nope/defects", session_headers(s))->status, 404);
  // Preparing it as it is is refused, and the refusal advises the repair that can close a fin.
  auto r = c.Post("/api/kelvin/objects", session_headers(s), json{{"upload", up["upload"]}, {"lx", 0.3}}.dump(), "application/json");
  ASSERT_EQ(r->status, 400) << r->body;
  EXPECT_NE(body_json(r)["error"]["message"].get<std::string>().find("\"wrap\" can make it one (\"fix\" cannot"), std::string::npos) << r->body;
}

// Fixing the hole of a box's missing face fills it with a triangle in its plane: no input point
// moves (input → fixed 0), and the patch's farthest point from the input is at most the removed
// triangle's inradius, s (2 − √2) / 2 (its edges are the input's): the reported distance is the
// bounded-error one (hausdorff_distance), within its relative error of that.
TEST_F(UploadLinks, AFixReportsItsHausdorffDistances) {
  const std::string s = new_session(c);
  const double side = 0.4;
  const json up = body_json(upload(s, obj_text(open_box(side, 5)), "format=obj"));
  auto r = c.Post("/api/kelvin/objects", session_headers(s),
                  json{{"upload", up["upload"]}, {"lx", 0.2}, {"repair", "fix"}, {"repair_options", {{"max_hole_edges", 3}}}}.dump(), "application/json");
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string id = body_json(r)["object"]["id"];
  json st;
  for (int i = 0; i < 1200; ++i) {
    st = get_json(c, s, "/api/kelvin/objects/" + id);
    if (st["state"] != "preparing" && st["state"] != "repairing") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_EQ(st["state"], "ready") << st.dump();
  const json h = st["repair_report"]["hausdorff"];
  const double inradius = side * (2 - std::sqrt(2.0)) / 2;
  std::printf("fix: %s, inradius %g\n", h.dump().c_str(), inradius);
  EXPECT_LE(h["input_to_fixed"].get<double>(), 1e-12) << h.dump();
  EXPECT_LE(h["fixed_to_input"].get<double>(), inradius * (1 + 1e-9)) << h.dump();
  EXPECT_GE(h["fixed_to_input"].get<double>(), (1 - mesh::kReportedRelativeError) * inradius) << h.dump();
}

}  // namespace
}  // namespace distlab::test
