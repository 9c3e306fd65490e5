// The service's API without Kelvin preparation: health, version, OpenAPI coverage, sessions,
// GAP distance and level sets, static files, and every kind of bad input.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <set>
#include <thread>

#include "distlab/server/frames.hpp"
#include "distlab/server/modules.hpp"
#include "server/server_fixture.hpp"

namespace distlab::test {
namespace {

ServerProcess* g_server = nullptr;

class Api : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { g_server = new ServerProcess(); }
  static void TearDownTestSuite() {
    EXPECT_EQ(g_server->stop(), 0) << "the server did not exit cleanly";
    delete g_server;
    g_server = nullptr;
  }
  httplib::Client c = g_server->client();
};

const char* kPair = R"({"a": {"type": "box", "size": [1, 1, 1]},
  "b": {"type": "sphere", "radius": 0.5, "pose": {"position": [2, 0, 0]}}})";

TEST_F(Api, HealthAndVersion) {
  auto r = c.Get("/api/health");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(body_json(r)["status"], "ok");
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/json");
  r = c.Get("/api/version");
  ASSERT_TRUE(r);
  EXPECT_EQ(body_json(r)["name"], "distlab");
  EXPECT_TRUE(body_json(r)["version"].is_string());
  r = c.Get("/api/limits");
  ASSERT_TRUE(r);
  EXPECT_GT(body_json(r)["max_body_bytes"].get<long>(), 0);
}

TEST_F(Api, OpenApiDocumentsEveryRouteAndNothingElse) {
  auto r = c.Get("/api/openapi.json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  const json doc = body_json(r);
  ASSERT_TRUE(doc.is_object());
  EXPECT_EQ(doc["openapi"], "3.1.0");
  const json& paths = doc["paths"];
  // The routes the server really registers (the same Service the binary runs).
  const TempDir cache("distlab-openapi");
  server::ServiceConfig cfg;
  cfg.cache_dir = cache.path();
  cfg.compute_threads = cfg.job_threads = 1;
  std::set<std::string> registered, documented;
  {
    server::Service service(cfg);
    server::add_standard_modules(service);
    for (const auto& route : service.router().routes()) {
      std::string m = route.method;
      for (auto& ch : m) ch = static_cast<char>(std::tolower(ch));
      registered.insert(m + " " + route.pattern);
    }
  }
  for (const auto& [path, ops] : paths.items())
    for (const auto& [method, op] : ops.items()) {
      documented.insert(method + " " + path);
      EXPECT_TRUE(op.contains("responses")) << method << " " << path;
      EXPECT_TRUE(op.contains("summary")) << method << " " << path;
    }
  documented.erase("get /ws");  // the WebSocket upgrade is served by the transport, not the router
  EXPECT_EQ(registered, documented);
  // And every documented operation exists on the live server: no unknown_route / 405.
  for (const auto& [path, ops] : paths.items()) {
    if (path == "/ws") continue;
    std::string p = path;
    for (std::size_t b; (b = p.find('{')) != std::string::npos;) p.replace(b, p.find('}') - b + 1, "0123");
    for (const auto& [method_key, op] : ops.items()) {
      const std::string method = method_key;  // clang 14 cannot capture a structured binding
      auto send = [&]() {
        if (method == "post") return c.Post(p, "", "application/json");
        if (method == "put") return c.Put(p, "", "application/json");
        if (method == "delete") return c.Delete(p);
        return c.Get(p);
      };
      auto res = send();
      ASSERT_TRUE(res) << method << " " << p;
      EXPECT_NE(res->status, 405) << method << " " << p;
      if (res->status == 404) {
        EXPECT_NE(body_json(res)["error"]["code"], "unknown_route") << method << " " << p;
      }
      // Documented statuses only.
      EXPECT_TRUE(op["responses"].contains(std::to_string(res->status)))
          << method << " " << p << " answered " << res->status << " " << res->body;
    }
  }
}

TEST_F(Api, UnknownRouteAndMethod) {
  expect_error(c.Get("/api/nope"), 404, "unknown_route");
  expect_error(c.Delete("/api/health"), 405, "method_not_allowed");
  expect_error(c.Post("/api/gap/nope", "{}", "application/json"), 404, "unknown_route");
}

TEST_F(Api, GapDistanceOnePairAndBatch) {
  auto r = c.Post("/api/gap/distance", kPair, "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  json j = body_json(r);
  EXPECT_TRUE(j["converged"].get<bool>());
  EXPECT_NEAR(j["euclidean"]["distance"].get<double>(), 1.0, 1e-6);
  EXPECT_GT(j["distance"].get<double>(), 0.0);
  const json pair = json::parse(kPair);
  json batch = {{"pairs", json::array({pair, pair, pair})}, {"params", {{"gradient", false}}}};
  r = c.Post("/api/gap/distance", batch.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  j = body_json(r);
  ASSERT_EQ(j["results"].size(), 3u);
  EXPECT_DOUBLE_EQ(j["results"][0]["distance"].get<double>(), j["results"][2]["distance"].get<double>());
}

// The Euclidean signed distance beside Λ, against closed forms: overlapping spheres (depth
// r1 + r2 - |c1 - c2| along the centre line), axis-aligned boxes (depth the smallest overlap of
// the extents, along that axis), and apart shapes (signed distance = distance, no penetration).
TEST_F(Api, GapDistancePenetrationClosedForms) {
  const auto vec = [](const json& v) { return Vec3(v[0].get<double>(), v[1].get<double>(), v[2].get<double>()); };
  const Vec3 c1(0.1, -0.2, 0.3), e = Vec3(1, 2, -2) / 3.0;
  const double r1 = 0.5, r2 = 0.45, L = 0.6;  // (a sphere of radius 0.7 fails Property 2 at the default ε)
  const Vec3 c2 = c1 + L * e;
  const json spheres = {{"a", {{"type", "sphere"}, {"radius", r1}, {"pose", {{"position", {c1.x(), c1.y(), c1.z()}}}}}},
                        {"b", {{"type", "sphere"}, {"radius", r2}, {"pose", {{"position", {c2.x(), c2.y(), c2.z()}}}}}}};
  // Boxes 1 x 0.8 x 0.6 and 0.6 x 0.6 x 0.6 with centres (0.7, -0.1, 0.05) apart: overlaps of the
  // extents 0.8 - 0.7 = 0.1 (x), 0.7 - 0.1 = 0.6 (y), 0.6 - 0.05 = 0.55 (z); depth 0.1 along +x.
  const json boxes = {{"a", {{"type", "box"}, {"size", {1.0, 0.8, 0.6}}}},
                      {"b", {{"type", "box"}, {"size", {0.6, 0.6, 0.6}}, {"pose", {{"position", {0.7, -0.1, 0.05}}}}}}};
  const json apart = json::parse(kPair);
  const json batch = {{"pairs", json::array({spheres, boxes, apart})}};
  auto r = c.Post("/api/gap/distance", batch.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const json res = body_json(r)["results"];
  ASSERT_EQ(res.size(), 3u);

  const json& s = res[0];
  EXPECT_TRUE(s["overlap"].get<bool>());
  EXPECT_EQ(s["euclidean"]["distance"].get<double>(), 0.0);
  const json& sp = s["euclidean"]["penetration"];
  EXPECT_NEAR(sp["depth"].get<double>(), r1 + r2 - L, 1e-9);
  EXPECT_DOUBLE_EQ(s["euclidean"]["signed_distance"].get<double>(), -sp["depth"].get<double>());
  EXPECT_LT((vec(sp["direction"]) - e).norm(), 1e-6);
  EXPECT_LT((vec(sp["witness_a"]) - (c1 + r1 * e)).norm(), 1e-6);
  EXPECT_LT((vec(sp["witness_b"]) - (c2 - r2 * e)).norm(), 1e-6);

  const json& b = res[1];
  EXPECT_TRUE(b["overlap"].get<bool>());
  const json& bp = b["euclidean"]["penetration"];
  EXPECT_NEAR(bp["depth"].get<double>(), 0.1, 1e-12);
  EXPECT_NEAR(b["euclidean"]["signed_distance"].get<double>(), -0.1, 1e-12);
  EXPECT_LT((vec(bp["direction"]) - Vec3::UnitX()).norm(), 1e-12);
  EXPECT_NEAR(vec(bp["witness_a"]).x(), 0.5, 1e-12);  // A's +x face
  EXPECT_NEAR(vec(bp["witness_b"]).x(), 0.4, 1e-12);  // B's -x face
  EXPECT_LT((vec(bp["witness_a"]) - vec(bp["witness_b"]) - 0.1 * Vec3::UnitX()).norm(), 1e-12);

  const json& a = res[2];
  EXPECT_FALSE(a["overlap"].get<bool>());
  EXPECT_FALSE(a["euclidean"].contains("penetration"));
  EXPECT_DOUBLE_EQ(a["euclidean"]["signed_distance"].get<double>(), a["euclidean"]["distance"].get<double>());
  EXPECT_NEAR(a["euclidean"]["signed_distance"].get<double>(), 1.0, 1e-9);
}

TEST_F(Api, GapBadInputs) {
  expect_error(c.Post("/api/gap/distance", "{\"a\": ", "application/json"), 400, "malformed_json");
  expect_error(c.Post("/api/gap/distance", "", "application/json"), 400, "empty_body");
  expect_error(c.Post("/api/gap/distance", "[1, 2]", "application/json"), 400, "invalid_input");
  json bad = json::parse(kPair);
  bad["b"]["radius"] = "big";
  expect_error(c.Post("/api/gap/distance", bad.dump(), "application/json"), 400, "invalid_input", "b.radius");
  bad = json::parse(kPair);
  bad["a"]["size"][1] = -1;
  expect_error(c.Post("/api/gap/distance", bad.dump(), "application/json"), 400, "invalid_input", "a.size[1]");
  bad = json::parse(kPair);
  bad["params"] = {{"k", 99}};
  expect_error(c.Post("/api/gap/distance", bad.dump(), "application/json"), 400, "invalid_input", "params.k");
  expect_error(c.Post("/api/gap/distance", "{\"a\": 1e999}", "application/json"), 400, "invalid_input");
  std::string deep(10000, '[');
  expect_error(c.Post("/api/gap/distance", deep, "application/json"), 400, "*");
  json many = {{"pairs", json::array()}};
  for (int i = 0; i < 2001; ++i) many["pairs"].push_back(json::parse(kPair));
  expect_error(c.Post("/api/gap/distance", many.dump(), "application/json"), 413, "too_many_pairs", "pairs");
  // Binary junk and invalid UTF-8 never crash the server.
  std::string junk;
  for (int i = 0; i < 4096; ++i) junk.push_back(static_cast<char>((i * 7919) & 0xFF));
  auto r = c.Post("/api/gap/distance", junk, "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_EQ(c.Get("/api/health")->status, 200);
}

TEST_F(Api, BodyTooLarge) {
  std::string big(9u << 20, ' ');  // over the 8 MiB default
  auto r = c.Post("/api/gap/distance", big, "application/json");
  if (r) {  // the server answers 413 and closes; a client may see the reset first
    expect_error(r, 413, "body_too_large");
  }
  // A raw request announcing a huge body is refused before it is sent.
  const std::string resp = raw_http(g_server->port(),
                                    "POST /api/gap/distance HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                                    "Content-Length: 100000000000\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(raw_status(resp), 413) << resp;
  EXPECT_EQ(c.Get("/api/health")->status, 200);
}

TEST_F(Api, MalformedHttpAndHugeHeaders) {
  std::string resp = raw_http(g_server->port(), "GARBAGE\r\n\r\n");
  EXPECT_EQ(raw_status(resp), 400) << resp;
  resp = raw_http(g_server->port(), "GET /api/health HTTP/1.1\r\nHost: x\r\nX-Big: " + std::string(20000, 'a') +
                                        "\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(raw_status(resp), 431) << resp;
  EXPECT_EQ(c.Get("/api/health")->status, 200);
}

TEST_F(Api, StaticFilesAndNoTraversal) {
  auto r = c.Get("/");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_NE(r->body.find("distlab test"), std::string::npos);
  EXPECT_EQ(r->get_header_value("Content-Type"), "text/html; charset=utf-8");
  r = c.Get("/js/app.js");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "text/javascript; charset=utf-8");
  expect_error(c.Get("/missing.png"), 404, "not_found");
  const std::string secret = fs::path(g_server->web_dir()).filename().string() + "-secret.txt";
  for (const std::string& target : std::vector<std::string>{"/../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd", "/%2E%2E/%2E%2E/etc/passwd", "/js/../../" + secret,
                                                            "/%2e%2e/" + secret, "/..%2f" + secret, "/..%5c" + secret, "/js/%2e%2e/%2e%2e/" + secret,
                                                            "/%00/etc/passwd", "/%2e%2e%2f%2e%2e%2fetc%2fpasswd", "//etc/passwd", "/./../" + secret}) {
    const std::string resp =
        raw_http(g_server->port(), "GET " + target + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    EXPECT_TRUE(raw_status(resp) == 404 || raw_status(resp) == 400) << target << "\n"
                                                                    << resp;
    EXPECT_EQ(resp.find("root:"), std::string::npos) << target;
    EXPECT_EQ(resp.find("secret"), std::string::npos) << target;
  }
}

// A scene item's frame (up to max_scene_bytes) is read only for a caller with a session: without
// one the answer is 401 whatever the body, with one the same body is the frame's 400.
TEST_F(Api, SceneItemIsReadAfterTheSession) {
  const std::string body = "\xc1 not msgpack";
  expect_error(c.Put("/api/scene/items/a", body, "application/msgpack"), 401, "session_required");
  expect_error(c.Put("/api/scene/items/a", session_headers(new_session(c)), body, "application/msgpack"), 400, "invalid_input");
}

TEST_F(Api, SessionsAreIsolatedAndUnguessable) {
  const std::string a = new_session(c), b = new_session(c);
  ASSERT_EQ(a.size(), 32u);
  ASSERT_NE(a, b);
  auto r = c.Get("/api/session", session_headers(a));
  ASSERT_TRUE(r);
  EXPECT_EQ(body_json(r)["session"], a);
  expect_error(c.Get("/api/session"), 401, "session_required");
  expect_error(c.Get("/api/session", session_headers("0123456789abcdef0123456789abcdef")), 404, "unknown_session");
  expect_error(c.Get("/api/kelvin/objects", session_headers(a + "x")), 404, "unknown_session");
  // Cookie works too.
  r = c.Get("/api/session", {{"Cookie", "theme=dark; distlab_session=" + b}});
  ASSERT_TRUE(r);
  EXPECT_EQ(body_json(r)["session"], b);
  // A's inline object is invisible to B.
  json cube = {{"mesh", {{"vertices", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}, {"faces", {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}}}},
               {"lx", 0.3}};
  r = c.Post("/api/kelvin/objects", session_headers(a), cube.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string id = body_json(r)["object"]["id"];
  const std::string job = body_json(r)["job"]["id"];
  EXPECT_EQ(c.Get(("/api/kelvin/objects/" + id), session_headers(a))->status, 200);
  expect_error(c.Get(("/api/kelvin/objects/" + id), session_headers(b)), 404, "unknown_object");
  expect_error(c.Put(("/api/kelvin/objects/" + id + "/sigma"), session_headers(b), "{\"constant\": 1}", "application/json"),
               404, "unknown_object");
  expect_error(c.Delete(("/api/kelvin/objects/" + id), session_headers(b)), 404, "unknown_object");
  expect_error(c.Get(("/api/jobs/" + job), session_headers(b)), 404, "unknown_job");
  expect_error(c.Post(("/api/jobs/" + job + "/cancel"), session_headers(b), "", "application/json"), 404, "unknown_job");
  EXPECT_EQ(body_json(c.Get("/api/kelvin/objects", session_headers(b)))["objects"].size(), 0u);
  EXPECT_EQ(body_json(c.Get("/api/jobs", session_headers(b)))["jobs"].size(), 0u);
  // Deleting A ends it.
  EXPECT_EQ(c.Delete("/api/session", session_headers(a))->status, 204);
  expect_error(c.Get("/api/session", session_headers(a)), 404, "unknown_session");
}

TEST_F(Api, GapLevelsetsMsgpack) {
  json req = {{"shape", {{"type", "box"}, {"size", {1, 0.6, 0.4}}}},
              {"levels", {{"weak", {0.05, 0.2}}, {"strict", {0.1}}}},
              {"grid", {{"resolution", 32}}},
              {"plane", {{"normal", {0, 0, 1}}, {"size", {3, 3}}, {"resolution", {64, 48}}}}};
  auto r = c.Post("/api/gap/levelsets", req.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/msgpack");
  const json doc = json::from_msgpack(r->body);
  EXPECT_EQ(doc["type"], "gap_levelsets");
  ASSERT_EQ(doc["surfaces"].size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const json& s = doc["surfaces"][i];
    EXPECT_EQ(s["field"], i < 2 ? "weak" : "strict");
    const auto pos = server::read_float32(s["positions"]);
    const auto idx = server::read_uint32(s["indices"]);
    ASSERT_GT(s["n_faces"].get<long>(), 10);
    EXPECT_EQ(pos.size(), 3u * s["n_vertices"].get<std::size_t>());
    EXPECT_EQ(idx.size(), 3u * s["n_faces"].get<std::size_t>());
    for (auto k : idx) ASSERT_LT(k, s["n_vertices"].get<std::uint32_t>());
  }
  const auto weak = server::read_float32(doc["plane"]["weak"]);
  const auto strict = server::read_float32(doc["plane"]["strict"]);
  ASSERT_EQ(weak.size(), 64u * 48u);
  ASSERT_EQ(strict.size(), 64u * 48u);
  // The centre of the plane is inside the box: both fields vanish there (nearly: the lattice
  // has no node exactly at the centre), and they grow towards the corners.
  EXPECT_LT(weak[32 + 64 * 24], 1e-6);
  EXPECT_GT(weak[0], 0.1);
  EXPECT_GT(strict[0], 0.0);
  // format=json gives a summary.
  req["format"] = "json";
  r = c.Post("/api/gap/levelsets", req.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  EXPECT_GT(body_json(r)["surfaces"][0]["n_faces"].get<long>(), 0);
}

TEST_F(Api, GapLevelsetsBadInputs) {
  json ok = {{"shape", {{"type", "sphere"}, {"radius", 0.5}}}, {"levels", {{"weak", {0.1}}}}};
  json bad = ok;
  bad["levels"]["weak"] = {-1};
  expect_error(c.Post("/api/gap/levelsets", bad.dump(), "application/json"), 400, "invalid_input", "levels.weak[0]");
  bad = ok;
  bad["grid"] = {{"resolution", 100000}};
  expect_error(c.Post("/api/gap/levelsets", bad.dump(), "application/json"), 400, "invalid_input", "grid.resolution");
  bad = ok;
  bad["grid"] = {{"resolution", "fine"}};
  expect_error(c.Post("/api/gap/levelsets", bad.dump(), "application/json"), 400, "invalid_input", "grid.resolution");
  bad = ok;
  bad["plane"] = {{"normal", {0, 0, 0}}};
  expect_error(c.Post("/api/gap/levelsets", bad.dump(), "application/json"), 400, "invalid_input", "plane.normal");
  bad = ok;
  bad["shape"]["radius"] = -2;
  expect_error(c.Post("/api/gap/levelsets", bad.dump(), "application/json"), 400, "invalid_input", "shape.radius");
  bad = ok;
  bad["surprise"] = 1;
  expect_error(c.Post("/api/gap/levelsets", bad.dump(), "application/json"), 400, "invalid_input", "surprise");
  bad = ok;
  bad["levels"]["weak"] = json::array();
  for (int i = 0; i < 100; ++i) bad["levels"]["weak"].push_back(0.1 + i);
  expect_error(c.Post("/api/gap/levelsets", bad.dump(), "application/json"), 413, "too_many_levels", "levels.weak");
}

TEST_F(Api, WebSocketNeedsASessionAndSurvivesBadMessages) {
  // No or unknown session: the upgrade is refused.
  EXPECT_THROW(WsClient(g_server->port(), "nope"), std::exception);
  const std::string s = new_session(c);
  WsClient ws(g_server->port(), s);
  WsClient::Message m;
  ASSERT_TRUE(ws.read(m));
  EXPECT_EQ(m.j["type"], "hello");
  EXPECT_EQ(m.j["session"], s);
  ws.send({{"type", "ping"}});
  ASSERT_TRUE(ws.read(m));
  EXPECT_EQ(m.j["type"], "pong");
  ws.send_raw("{not json");
  ASSERT_TRUE(ws.read(m));
  EXPECT_EQ(m.j["type"], "error");
  EXPECT_EQ(m.j["error"]["code"], "malformed_json");
  ws.send({{"type", "teleport"}});
  ASSERT_TRUE(ws.read(m));
  EXPECT_EQ(m.j["error"]["field"], "type");
  ws.send({{"type", "sigma"}, {"object", "0123"}, {"sigma", {{"constant", 1}}}});
  ASSERT_TRUE(ws.read(m));
  EXPECT_EQ(m.j["error"]["code"], "unknown_object");
  ws.send({{"type", "cancel"}, {"job", "0123"}});
  ASSERT_TRUE(ws.read(m));
  EXPECT_EQ(m.j["error"]["code"], "unknown_job");
  EXPECT_EQ(c.Get("/api/health")->status, 200);
}

TEST(ApiLimits, WebSocketMessageSizeAndRate) {
  ServerProcess server({"--max-ws-message-bytes", "1000", "--ws-rate", "5", "--ws-burst", "5"});
  auto c = server.client();
  const std::string s = new_session(c);
  {
    WsClient ws(server.port(), s);
    WsClient::Message m;
    ASSERT_TRUE(ws.read(m));  // hello
    int errors = 0, pongs = 0;
    for (int i = 0; i < 20; ++i) ws.send({{"type", "ping"}, {"request", i}});
    std::set<int> refused;  // request ids of the refused messages: each names its message
    for (int i = 0; i < 20 && ws.read(m, 5); ++i) {
      if (m.j["type"] == "pong") ++pongs;
      if (m.j["type"] == "error" && m.j["error"]["code"] == "rate_limited") {
        ++errors;
        ASSERT_TRUE(m.j.contains("request")) << m.data;
        refused.insert(m.j["request"].get<int>());
      }
    }
    EXPECT_EQ(refused.size(), static_cast<std::size_t>(errors));
    if (!refused.empty()) {
      EXPECT_GE(*refused.begin(), 4);  // the burst's first messages were served
    }
    EXPECT_GE(pongs, 4);
    EXPECT_LE(pongs, 8);
    EXPECT_GE(errors, 12);
    // A client that keeps going far past the limit is disconnected (1008).
    try {
      for (int i = 0; i < 300; ++i) ws.send({{"type", "ping"}});
    } catch (const std::exception&) {  // the server may close before the last ones are sent
    }
    while (ws.read(m, 5)) {
    }
    EXPECT_EQ(ws.close_reason().code, boost::beast::websocket::close_code::policy_error);
  }
  {
    WsClient ws(server.port(), s);
    WsClient::Message m;
    ASSERT_TRUE(ws.read(m));  // hello
    try {
      ws.send_raw(std::string(5000, ' '));
    } catch (const std::exception&) {  // the server may close while the frame is being sent
    }
    EXPECT_FALSE(ws.read(m, 10));  // closed: message too big
  }
  EXPECT_EQ(c.Get("/api/health")->status, 200);
  EXPECT_EQ(server.stop(), 0);
}

// Every synchronous heavy request names the limits that bound it (GET /api/limits), each a real
// limit; the time-bounded ones document 408 in the OpenAPI file; max_iter past the budget is 422.
TEST_F(Api, EveryHeavyRequestIsBounded) {
  const json limits = body_json(c.Get("/api/limits"));
  const json doc = json::parse(body_json(c.Get("/api/openapi.json")).dump());
  ASSERT_TRUE(limits["request_bounds"].is_object()) << limits.dump();
  for (const char* route : {"POST /api/gap/distance", "POST /api/gap/levelsets", "POST /api/kelvin/uploads",
                            "POST /api/kelvin/objects", "POST /api/kelvin/objects/{id}/query",
                            "GET /api/kelvin/objects/{id}/isosurface", "GET /api/kelvin/objects/{id}/export",
                            "POST /api/cbf/rollouts", "GET /api/cbf/rollouts/{id}/frames",
                            "GET /api/cbf/rollouts/{id}/record", "POST /api/robot/distances"}) {
    ASSERT_TRUE(limits["request_bounds"].contains(route)) << route;
    EXPECT_FALSE(limits["request_bounds"][route].empty()) << route << " has no explicit bound";
  }
  for (const auto& [route, names] : limits["request_bounds"].items()) {
    for (const auto& n : names) EXPECT_TRUE(limits.contains(n.get<std::string>())) << route << ": " << n;
    const auto space = route.find(' ');
    std::string method = route.substr(0, space);
    std::transform(method.begin(), method.end(), method.begin(), [](unsigned char ch) { return std::tolower(ch); });
    const json& op = doc["paths"][route.substr(space + 1)][method];
    if (std::find(names.begin(), names.end(), "max_request_seconds") != names.end()) {
      EXPECT_TRUE(op["responses"].contains("408")) << route << " is time-bounded but documents no 408";
    }
  }
  json body = json::parse(kPair);
  body["params"] = {{"max_iter", limits["max_gap_iterations"].get<long>() + 1}};
  expect_error(c.Post("/api/gap/distance", body.dump(), "application/json"), 422, "over_budget", "params.max_iter");
  body["params"] = {{"max_iter", limits["max_gap_iterations"].get<long>()}};
  EXPECT_EQ(c.Post("/api/gap/distance", body.dump(), "application/json")->status, 200);
}

// Every limit GET /api/limits reports is documented in the OpenAPI schema of /api/limits, and the
// schema names no limit the server does not report.
TEST_F(Api, EveryLimitIsDocumented) {
  const json limits = body_json(c.Get("/api/limits"));
  const json doc = body_json(c.Get("/api/openapi.json"));
  const json& props =
      doc["paths"]["/api/limits"]["get"]["responses"]["200"]["content"]["application/json"]["schema"]["properties"];
  ASSERT_TRUE(props.is_object());
  std::set<std::string> reported, documented;
  for (const auto& [k, v] : limits.items()) reported.insert(k);
  for (const auto& [k, v] : props.items()) {
    documented.insert(k);
    EXPECT_TRUE(k == "request_bounds" || v.contains("description")) << k << " has no description";
  }
  EXPECT_EQ(reported, documented);
}

// With a tiny time per request, a GAP batch, a level-set grid and a Kelvin query stop with 408
// time_limit (their checks run between chunks), and the server keeps serving.
TEST(ApiLimits, TimeLimitPerRequest) {
  ServerProcess server({"--max-request-seconds", "0.000001"});
  auto c = server.client();
  json pairs = json::array();
  for (int i = 0; i < 200; ++i) pairs.push_back(json::parse(kPair));
  auto r = c.Post("/api/gap/distance", json{{"pairs", pairs}}.dump(), "application/json");
  expect_error(r, 408, "time_limit", "");
  const json levelsets = {{"shape", {{"type", "box"}, {"size", {1, 0.6, 0.4}}}},
                          {"levels", {{"weak", {0.05}}}},
                          {"grid", {{"resolution", 32}}}};
  expect_error(c.Post("/api/gap/levelsets", levelsets.dump(), "application/json"), 408, "time_limit", "");
  const std::string s = new_session(c);
  r = c.Post("/api/kelvin/objects", session_headers(s), json{{"asset", "cube"}, {"lx", 0.3}}.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string id = body_json(r)["object"]["id"];
  std::string state;
  for (int i = 0; i < 600 && state != "ready"; ++i) {
    state = body_json(c.Get(("/api/kelvin/objects/" + id), session_headers(s)))["state"];
    if (state != "ready") std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_EQ(state, "ready");
  r = c.Post(("/api/kelvin/objects/" + id + "/query"), session_headers(s),
             json{{"points", {{1.0, 0, 0}, {1.5, 0, 0}}}}.dump(), "application/json");
  expect_error(r, 408, "time_limit", "");
  EXPECT_EQ(c.Get("/api/health")->status, 200);
  EXPECT_EQ(server.stop(), 0);
}

TEST(ApiLimits, SmallBodyLimitAndSessionLimit) {
  ServerProcess server({"--max-body-bytes", "2000", "--max-sessions", "2"});
  auto c = server.client();
  std::string body = std::string(R"({"a": {"type": "sphere", "radius": 1}, "b": {"type": "sphere", "radius": 1, "pose": {"position": [3, 0, 0]}}, "comment": ")") +
                     std::string(3000, 'x') + "\"}";
  auto r = c.Post("/api/gap/distance", body, "application/json");
  if (r) {
    EXPECT_EQ(r->status, 413);
  }
  const std::string first = new_session(c);
  EXPECT_FALSE(first.empty());
  EXPECT_FALSE(new_session(c).empty());
  // Full: the least recently used session of the address holding the most (here the only one)
  // makes room; a session with an open WebSocket is never evicted, so then it is 429.
  const std::string third = new_session(c);
  EXPECT_FALSE(third.empty());
  EXPECT_EQ(c.Get("/api/session", session_headers(first))->status, 404);
  std::vector<std::unique_ptr<WsClient>> sockets;
  sockets.push_back(std::make_unique<WsClient>(server.port(), third));
  WsClient::Message hello;
  ASSERT_TRUE(sockets.back()->read(hello));
  const std::string fourth = new_session(c);  // evicts the second (no socket), not the third
  EXPECT_FALSE(fourth.empty());
  EXPECT_EQ(c.Get("/api/session", session_headers(third))->status, 200);
  sockets.push_back(std::make_unique<WsClient>(server.port(), fourth));
  ASSERT_TRUE(sockets.back()->read(hello));
  auto r3 = c.Post("/api/session", "", "application/json");
  ASSERT_TRUE(r3);
  EXPECT_EQ(r3->status, 429);
  EXPECT_EQ(body_json(r3)["error"]["code"], "too_many_sessions");
  sockets.clear();
  EXPECT_EQ(server.stop(), 0);
}

}  // namespace
}  // namespace distlab::test
