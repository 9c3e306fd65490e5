// CBF rollouts of scenarios with Kelvin fields through the service (issue 33): the job prepares the
// field in the server's own (temporary) cache directory, reporting Kelvin's stages before the
// rollout's; the frames carry h at every control point and the closest point, the same numbers as
// the record; GET .../fields gives the object in the file's vertex order with σ per vertex and the
// iso-surfaces of h; a bad field is refused by name before any job starts.
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <set>

#include "distlab/server/frames.hpp"
#include "server/server_fixture.hpp"

namespace distlab::test {
namespace {

using Msg = WsClient::Message;

class CbfFieldsApi : public SharedServerTest<CbfFieldsApi> {};

json wrench_grasp() {
  std::ifstream f(std::string(DISTLAB_SOURCE_DIR) + "/assets/scenarios/wrench_grasp.json");
  return json::parse(f);
}

// The wrench's vertices as the server numbers an STL's: distinct corners in order of first
// appearance, facet by facet (float32, as the file has them); and its facets in those numbers.
struct StlMesh {
  std::vector<std::array<float, 3>> vertices;
  std::vector<std::array<std::uint32_t, 3>> faces;
};
StlMesh read_binary_stl(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), {});
  StlMesh m;
  std::uint32_t n = 0;
  std::memcpy(&n, bytes.data() + 80, 4);
  std::map<std::array<float, 3>, std::uint32_t> index;
  for (std::uint32_t t = 0; t < n; ++t) {
    std::array<std::uint32_t, 3> face{};
    for (int k = 0; k < 3; ++k) {
      std::array<float, 3> v{};
      std::memcpy(v.data(), bytes.data() + 84 + 50 * t + 12 + 12 * k, 12);
      auto [it, added] = index.emplace(v, static_cast<std::uint32_t>(m.vertices.size()));
      if (added) m.vertices.push_back(v);
      face[k] = it->second;
    }
    m.faces.push_back(face);
  }
  return m;
}

// GET .../fields decoded (msgpack).
json get_fields(httplib::Client& c, const std::string& s, const std::string& id, const std::string& query = "") {
  auto r = c.Get("/api/cbf/rollouts/" + id + "/fields" + query, session_headers(s));
  EXPECT_TRUE(r);
  if (!r) return json();
  EXPECT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/msgpack");
  return json::from_msgpack(r->body);
}

std::string start(httplib::Client& c, const std::string& s, const json& body) {
  auto r = c.Post("/api/cbf/rollouts", session_headers(s), body.dump(), "application/json");
  EXPECT_TRUE(r);
  if (!r) return "";
  EXPECT_EQ(r->status, 202) << r->body;
  return body_json(r)["rollout"]["id"];
}

// Reads the socket until job `id` ends: its frames by index, and the job's stages in order.
std::string follow(WsClient& ws, const std::string& id, std::map<std::size_t, json>& frames, std::vector<std::string>* stages = nullptr) {
  Msg m;
  std::string final_state;
  const bool ok = ws.until(
      [&](const Msg& x) {
        if (x.binary) return false;
        if (x.j["type"] == "cbf_frames" && x.j["rollout"] == id)
          for (const json& f : x.j["frames"]) frames[f["i"].get<std::size_t>()] = f;
        if (x.j["type"] == "job" && x.j["job"]["id"] == id) {
          const std::string st = x.j["job"]["state"];
          if (stages && x.j["job"].contains("stage") && (stages->empty() || stages->back() != x.j["job"]["stage"]))
            stages->push_back(x.j["job"]["stage"]);
          if (st == "succeeded" || st == "failed" || st == "cancelled") final_state = st;
        }
        return !final_state.empty();
      },
      m, 600);
  EXPECT_TRUE(ok) << "no final job event for " << id;
  return final_state;
}

// Every edge of a closed, consistently oriented surface is used once in each direction.
bool closed(const std::vector<std::uint32_t>& indices) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (std::size_t t = 0; t + 2 < indices.size(); t += 3)
    for (int k = 0; k < 3; ++k) ++directed[{indices[t + k], indices[t + (k + 1) % 3]}];
  for (const auto& [e, n] : directed)
    if (n != 1 || directed.count({e.second, e.first}) == 0 || directed.at({e.second, e.first}) != 1) return false;
  return !directed.empty();
}

TEST_F(CbfFieldsApi, WrenchGraspPreparesInTheServersCacheStreamsAndRecords) {
  const std::string s = new_session(c);
  WsClient ws(server_->port(), s);
  await_hello(ws);
  auto r = c.Post("/api/cbf/rollouts", session_headers(s),
                  json{{"scenario", "wrench_grasp"}, {"metric", "euclidean"}, {"params", {{"duration", 0.3}}}}.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const json accepted = body_json(r)["rollout"];
  const std::string id = accepted["id"];
  ASSERT_TRUE(accepted.contains("kelvin"));
  EXPECT_EQ(accepted["kelvin"]["fields"][0]["name"], "wrench");
  EXPECT_EQ(accepted["kelvin"]["fields"][0]["delta"], 0.2);
  const std::size_t points = accepted["kelvin"]["control_points"].size();
  EXPECT_EQ(points, 24u + 2 * 16 + 2 * 8);

  std::map<std::size_t, json> frames;
  std::vector<std::string> stages;
  ASSERT_EQ(follow(ws, id, frames, &stages), "succeeded");
  // Kelvin's preparation stages come first, then the rollout's.
  ASSERT_FALSE(stages.empty());
  EXPECT_EQ(stages.back(), "rollout");
  EXPECT_TRUE(std::set<std::string>(stages.begin(), stages.end()).count("mesh")) << json(stages);
  // Prepared in the server's cache directory (a temporary one), not in $HOME's.
  bool cached = false;
  for (const auto& e : fs::directory_iterator(server_->cache_dir())) cached = cached || e.path().extension() == ".kelvin";
  EXPECT_TRUE(cached) << "no .kelvin file in " << server_->cache_dir();

  const json status = get_json(c, s, "/api/cbf/rollouts/" + id);
  EXPECT_EQ(status["kelvin"]["state"], "ready");
  const json rec = get_json(c, s, "/api/cbf/rollouts/" + id + "/record");
  ASSERT_EQ(rec["steps"], 30);
  ASSERT_TRUE(rec.contains("kelvin")) << rec.dump().substr(0, 300);
  const json& field = rec["kelvin"]["fields"][0];
  EXPECT_EQ(field["name"], "wrench");
  EXPECT_GT(field["safety_distance"].get<double>(), 0);
  EXPECT_EQ(rec["kelvin"]["control_points"], accepted["kelvin"]["control_points"]);
  // The frames carry the record's numbers (one codec): h at every point, the closest point, σ.
  ASSERT_EQ(frames.size(), 30u);
  for (std::size_t i = 0; i < 30; ++i) {
    const json& k = frames[i]["kelvin"][0];
    ASSERT_EQ(k["h"].size(), points);
    EXPECT_EQ(k["h"], field["h"][i]);
    EXPECT_EQ(k["closest"], field["closest"][i]);
    EXPECT_EQ(k["closest_sigma"], field["closest_sigma"][i]);
    EXPECT_EQ(k["closest_control_point"], field["closest_control_point"][i]);
    EXPECT_EQ(k["allowed_distance"], field["allowed_distance"][i]);
    EXPECT_EQ(k["forbidden_distance"], field["forbidden_distance"][i]);
    for (const json& h : k["h"]) EXPECT_GE(h.get<double>(), 0.2) << "step " << i;
  }

  // Feasibility and a sweep of the same scenario share the prepared field.
  auto f = c.Post("/api/cbf/feasibility", session_headers(s), json{{"scenario", "wrench_grasp"}}.dump(), "application/json");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->status, 200) << f->body;
  auto sw = c.Post("/api/cbf/sweeps", session_headers(s),
                   json{{"scenario", "wrench_grasp"}, {"metric", "euclidean"}, {"sweep", {{"parameter", "duration"}, {"values", {0.05, 0.1}}}}}.dump(),
                   "application/json");
  ASSERT_TRUE(sw);
  ASSERT_EQ(sw->status, 202) << sw->body;
  std::map<std::size_t, json> none;
  EXPECT_EQ(follow(ws, body_json(sw)["sweep"]["id"], none), "succeeded");
  const json sweep = get_json(c, s, "/api/cbf/sweeps/" + body_json(sw)["sweep"]["id"].get<std::string>());
  ASSERT_EQ(sweep["entries"].size(), 2u);
  EXPECT_EQ(sweep["entries"][1]["steps"], 10);
}

TEST_F(CbfFieldsApi, FieldsAreTheFileInItsOrderWithSigmaAndClosedIsosurfaces) {
  const std::string s = new_session(c);
  WsClient ws(server_->port(), s);
  await_hello(ws);
  const StlMesh stl = read_binary_stl(std::string(DISTLAB_SOURCE_DIR) + "/assets/wrench.stl");
  ASSERT_EQ(stl.vertices.size(), 584u);

  // σ per file vertex that depends on the index alone: any reordering shows.
  json per_vertex = json::array();
  for (std::size_t i = 0; i < stl.vertices.size(); ++i) per_vertex.push_back(0.4 * std::sin(0.7 * static_cast<double>(i)));
  for (const json& sigma : {json::object(), json{{"per_vertex", per_vertex}}}) {
    json params = {{"duration", 0.05}};
    if (!sigma.empty()) params["fields"] = json::array({{{"sigma", sigma}}});
    const std::string id = start(c, s, {{"scenario", "wrench_grasp"}, {"metric", "euclidean"}, {"params", params}});
    std::map<std::size_t, json> frames;
    ASSERT_EQ(follow(ws, id, frames), "succeeded");
    const json g = get_fields(c, s, id);
    ASSERT_EQ(g["type"], "cbf_fields");
    ASSERT_EQ(g["fields"].size(), 1u);
    const json& f = g["fields"][0];
    EXPECT_EQ(f["frame"], "object");
    EXPECT_EQ(f["pose"]["position"], json::array({0.5, 0.0, 0.0025}));
    const json& surface = f["surface"];
    const std::vector<float> pos = server::read_float32(surface["positions"]);
    const std::vector<std::uint32_t> idx = server::read_uint32(surface["indices"]);
    const std::vector<float> sig = server::read_float32(surface["scalars"]);
    ASSERT_EQ(pos.size(), 3 * stl.vertices.size());
    ASSERT_EQ(sig.size(), stl.vertices.size());
    for (std::size_t v = 0; v < stl.vertices.size(); ++v)
      for (int k = 0; k < 3; ++k) ASSERT_EQ(pos[3 * v + k], stl.vertices[v][k]) << "vertex " << v;
    ASSERT_EQ(idx.size(), 3 * stl.faces.size());
    for (std::size_t t = 0; t < stl.faces.size(); ++t)
      for (int k = 0; k < 3; ++k) ASSERT_EQ(idx[3 * t + k], stl.faces[t][k]) << "face " << t;
    EXPECT_TRUE(closed(idx));
    for (std::size_t v = 0; v < stl.vertices.size(); ++v) {
      // The scenario's σ: eq. 24's axis term about x (d0 3 cm, width 3 mm, −0.5 at the ends).
      const double x = stl.vertices[v][0];
      const double expected = sigma.empty() ? std::tanh((std::abs(x) - 0.03) / 0.003) * -0.5 : per_vertex[v].get<double>();
      ASSERT_NEAR(sig[v], expected, 1e-6) << "vertex " << v;
    }
    // Iso-surfaces at 0 and δ by default: closed, the δ one around the zero one.
    ASSERT_EQ(f["isosurfaces"].size(), 2u);
    EXPECT_EQ(f["isosurfaces"][0]["level"], 0.0);
    EXPECT_EQ(f["isosurfaces"][1]["level"], 0.2);
    for (const json& iso : f["isosurfaces"]) {
      EXPECT_GT(iso["n_faces"].get<int>(), 100);
      EXPECT_TRUE(closed(server::read_uint32(iso["indices"]))) << "level " << iso["level"];
    }
  }
}

TEST_F(CbfFieldsApi, LevelsAndStates) {
  const std::string s = new_session(c);
  WsClient ws(server_->port(), s);
  await_hello(ws);
  std::vector<std::string> ids;
  for (int k = 0; k < 3; ++k) {
    ids.push_back(start(c, s, {{"scenario", "wrench_grasp"}, {"metric", "euclidean"}, {"params", {{"duration", 0.02}}}}));
    std::map<std::size_t, json> frames;
    ASSERT_EQ(follow(ws, ids.back(), frames), "succeeded");
  }
  const json one = get_fields(c, s, ids[2], "?levels=0.1");
  ASSERT_EQ(one["fields"][0]["isosurfaces"].size(), 1u);
  EXPECT_EQ(one["fields"][0]["isosurfaces"][0]["level"], 0.1);
  // A level below the field's smallest h: no geometry, and that smallest h.
  const json low = get_fields(c, s, ids[2], "?levels=-50");
  EXPECT_EQ(low["fields"][0]["isosurfaces"][0]["empty"], true);
  EXPECT_GT(low["fields"][0]["isosurfaces"][0]["h_min"].get<double>(), -50);
  expect_error(c.Get("/api/cbf/rollouts/" + ids[2] + "/fields?levels=a", session_headers(s)), 400, "invalid_input", "levels");
  std::string many = "0";
  for (int k = 1; k <= 16; ++k) many += "," + std::to_string(k);
  expect_error(c.Get("/api/cbf/rollouts/" + ids[2] + "/fields?levels=" + many, session_headers(s)), 413, "too_many_levels", "levels");
  // The server keeps the fields of the newest cbf_fields_kept_total rollouts (2 by default).
  EXPECT_EQ(get_json(c, "", "/api/limits")["cbf_fields_kept_total"], 2);
  expect_error(c.Get("/api/cbf/rollouts/" + ids[0] + "/fields", session_headers(s)), 410, "fields_released", "");
  EXPECT_EQ(get_json(c, s, "/api/cbf/rollouts/" + ids[0])["kelvin"]["state"], "released");
  EXPECT_EQ(get_json(c, s, "/api/cbf/rollouts/" + ids[1])["kelvin"]["state"], "ready");
  // A scenario without fields has none; another session sees no rollout.
  const std::string plain = start(c, s, {{"scenario", "corridor"}, {"metric", "euclidean"}, {"params", {{"duration", 0.02}}}});
  std::map<std::size_t, json> frames;
  ASSERT_EQ(follow(ws, plain, frames), "succeeded");
  EXPECT_FALSE(frames[0].contains("kelvin"));
  EXPECT_FALSE(get_json(c, s, "/api/cbf/rollouts/" + plain).contains("kelvin"));
  expect_error(c.Get("/api/cbf/rollouts/" + plain + "/fields", session_headers(s)), 404, "no_fields", "");
  expect_error(c.Get("/api/cbf/rollouts/" + ids[2] + "/fields", session_headers(new_session(c))), 404, "unknown_rollout", "");
}

TEST_F(CbfFieldsApi, BadFieldsAreRefusedByNameBeforeAnyJob) {
  const std::string s = new_session(c);
  const json base = wrench_grasp();
  auto post = [&](const std::string& route, json scenario, const json& params = json::object()) {
    json body = {{"scenario", std::move(scenario)}, {"metric", "euclidean"}, {"params", params}};
    if (route == "/api/cbf/sweeps") body["sweep"] = {{"parameter", "duration"}, {"values", {0.1}}};
    return c.Post(route, session_headers(s), body.dump(), "application/json");
  };
  for (const std::string route : {"/api/cbf/rollouts", "/api/cbf/feasibility", "/api/cbf/sweeps"}) {
    SCOPED_TRACE(route);
    json sc = base;
    sc["fields"][0]["mesh"] = {{"asset", "nowhere"}};
    expect_error(post(route, sc), 400, "invalid_input", "scenario.fields[0].mesh.asset");
    sc = base;
    sc["fields"][0]["lx"] = 0.001;  // below min_lx
    expect_error(post(route, sc), 422, "over_budget", "scenario.fields[0].lx");
    sc = base;
    sc["fields"][0]["far_radius"] = 50;  // the vertex estimate over the budget
    expect_error(post(route, sc), 422, "over_budget", "scenario.fields[0].lx");
    sc = base;
    sc["fields"][0].erase("lx");
    sc["fields"][0]["lx_fraction"] = 0.001;
    expect_error(post(route, sc), 422, "over_budget", "scenario.fields[0].lx_fraction");
    sc = base;
    sc["fields"][0]["mesh"] = {{"path", std::string(DISTLAB_SOURCE_DIR) + "/assets/wrench.stl"}};
    expect_error(post(route, sc), 400, "invalid_input", "scenario.fields[0].mesh.path");
    sc = base;
    sc["control_points"][0]["link"] = "nowhere";
    expect_error(post(route, sc), 400, "invalid_input", "scenario.control_points[0].link");
    sc = base;
    sc["fields"][0]["sigma"] = {{"constant", 1000}};  // beyond max_abs_sigma
    expect_error(post(route, sc), 400, "invalid_input", "scenario.fields[0].sigma.constant");
    sc = base;
    sc.erase("control_points");
    expect_error(post(route, sc), 400, "invalid_input", "scenario.fields");
    expect_error(post(route, "wrench_grasp", {{"fields", json::array({json::object(), json::object()})}}), 400, "invalid_input", "params.fields");
  }
  EXPECT_TRUE(get_json(c, s, "/api/cbf/rollouts")["rollouts"].empty()) << "refused requests start nothing";
}

TEST_F(CbfFieldsApi, CancelWhilePreparing) {
  const std::string s = new_session(c);
  WsClient ws(server_->port(), s);
  await_hello(ws);
  json sc = wrench_grasp();
  sc["fields"][0]["lx"] = 0.0031;  // not prepared yet: its preparation takes seconds
  const std::string id = start(c, s, {{"scenario", sc}, {"metric", "euclidean"}, {"params", {{"duration", 0.1}}}});
  auto r = c.Post("/api/jobs/" + id + "/cancel", session_headers(s), "", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 202) << r->body;
  std::map<std::size_t, json> frames;
  EXPECT_EQ(follow(ws, id, frames), "cancelled");
  EXPECT_TRUE(frames.empty());
  const json status = get_json(c, s, "/api/cbf/rollouts/" + id);
  EXPECT_EQ(status["state"], "cancelled");
  EXPECT_NE(status["kelvin"]["state"], "ready");
}

}  // namespace
}  // namespace distlab::test
