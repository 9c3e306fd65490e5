// CBF rollouts through the service: scenarios, the robot model (checked by recomputing the
// streamed primitive poses from it), rollouts whose steps stream over the WebSocket, replay to a
// late joiner, cancellation midway, session isolation, bad input, and the record compared number
// for number with `distlab cbf` on the same request.
#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <set>

#include "server/server_fixture.hpp"

namespace distlab::test {
namespace {

using Msg = WsClient::Message;

class CbfApi : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { server_ = new ServerProcess(); }
  static void TearDownTestSuite() {
    EXPECT_EQ(server_->stop(), 0) << "the server did not exit cleanly";
    delete server_;
  }
  static ServerProcess* server_;
  httplib::Client c = server_->client();
};
ServerProcess* CbfApi::server_ = nullptr;

// A WebSocket of session s, after its "hello" (the server has registered it: broadcasts reach it).
std::unique_ptr<WsClient> connect(int port, const std::string& s) {
  auto ws = std::make_unique<WsClient>(port, s);
  await_hello(*ws);
  return ws;
}

httplib::Result post_rollout(httplib::Client& c, const std::string& s, const json& body) {
  return c.Post("/api/cbf/rollouts", session_headers(s), body.dump(), "application/json");
}

std::string start(httplib::Client& c, const std::string& s, const json& body) {
  auto r = post_rollout(c, s, body);
  EXPECT_TRUE(r);
  if (!r) return "";
  EXPECT_EQ(r->status, 202) << r->body;
  const json j = body_json(r);
  EXPECT_EQ(j["rollout"]["id"], j["job"]["id"]);
  EXPECT_EQ(j["job"]["kind"], "cbf_rollout");
  return j["rollout"]["id"];
}

// Reads WebSocket messages until the job `id` ends; collects its cbf_frames steps by index.
std::string follow(WsClient& ws, const std::string& id, std::map<std::size_t, json>& frames, int* messages = nullptr,
                   const std::function<void(const json&)>& on_frames = {}) {
  Msg m;
  std::string final_state;
  const bool ok = ws.until(
      [&](const Msg& x) {
        if (x.binary) return false;
        if (x.j["type"] == "cbf_frames" && x.j["rollout"] == id) {
          if (messages) ++*messages;
          EXPECT_EQ(x.j["count"], x.j["frames"].size());
          for (const json& f : x.j["frames"]) frames[f["i"].get<std::size_t>()] = f;
          if (on_frames) on_frames(x.j);
        }
        if (x.j["type"] == "job" && x.j["job"]["id"] == id) {
          const std::string st = x.j["job"]["state"];
          if (st == "succeeded" || st == "failed" || st == "cancelled") final_state = st;
        }
        return !final_state.empty();
      },
      m, 300);
  EXPECT_TRUE(ok) << "no final job event for " << id;
  return final_state;
}

// POST /api/jobs/{id}/cancel as session s; true when accepted.
bool cancel_job(httplib::Client& c, const std::string& s, const std::string& id) {
  auto r = c.Post(("/api/jobs/" + id + "/cancel"), session_headers(s), "", "application/json");
  EXPECT_TRUE(r);
  if (!r) return false;
  EXPECT_EQ(r->status, 202) << r->body;
  return r->status == 202;
}

std::string flag_text(const std::vector<std::string>& flags) {
  std::string t;
  for (const std::string& f : flags) t += " " + f;
  return t;
}

// `distlab cbf` on the same request.
json run_cli(const json& request, const std::vector<std::string>& flags = {}) {
  const TempDir dir("distlab-cbf-cli");
  const std::string in = dir.path() + "/request.json", out = dir.path() + "/record.json";
  std::ofstream(in) << request.dump();
  const std::string cmd = "DISTLAB_ASSETS='" + std::string(DISTLAB_SOURCE_DIR) + "/assets' '" + DISTLAB_EXE +
                          "' cbf" + flag_text(flags) + " < '" + in + "' > '" + out + "'";
  const int rc = std::system(cmd.c_str());
  EXPECT_EQ(rc, 0) << cmd;
  std::ifstream f(out);
  return json::parse(f, nullptr, false);
}

TEST_F(CbfApi, ScenariosAndRobot) {
  json j = get_json(c, "", "/api/cbf/scenarios");
  ASSERT_TRUE(j["scenarios"].is_array());
  EXPECT_NE(std::find(j["scenarios"].begin(), j["scenarios"].end(), "corridor"), j["scenarios"].end()) << j;
  EXPECT_GT(j["limits"]["max_steps"].get<int>(), 0);
  EXPECT_GT(j["limits"]["max_pair_steps"].get<int>(), 0);

  const json corridor = get_json(c, "", "/api/cbf/scenarios/corridor");
  std::ifstream f(std::string(DISTLAB_SOURCE_DIR) + "/assets/scenarios/corridor.json");
  EXPECT_EQ(corridor, json::parse(f)) << "the scenario is the file's JSON";
  expect_error(c.Get("/api/cbf/scenarios/nowhere"), 404, "unknown_scenario", "name");
  expect_error(c.Get("/api/cbf/scenarios/..%2Fsecret"), 400, "invalid_input", "name");

  const json robot = get_json(c, "", "/api/cbf/robot");
  ASSERT_EQ(robot["dof"], 7);
  ASSERT_EQ(robot["q_min"].size(), 7u);
  ASSERT_EQ(robot["primitives"].size(), 9u);
  const long links = static_cast<long>(robot["links"].size());
  for (const json& p : robot["primitives"]) {
    EXPECT_GE(p["link"].get<int>(), 1);
    EXPECT_LT(p["link"].get<int>(), links);
    EXPECT_TRUE(p["shape"]["type"] == "box" || p["shape"]["type"] == "cylinder") << p;
    EXPECT_EQ(p["pose"]["quaternion"].size(), 4u);
  }
  EXPECT_EQ(robot["primitives"][4]["name"], "link5_box");
  EXPECT_EQ(robot["primitives"][4]["shape"]["size"], json::array({0.08, 0.05, 0.23}));
  EXPECT_EQ(get_json(c, "", "/api/cbf/robot?name=ur5e")["dof"], 6);
  expect_error(c.Get("/api/cbf/robot?name=nowhere"), 400, "invalid_input", "name");
  expect_error(c.Get("/api/cbf/robot?name=..%2Fsecret"), 400, "invalid_input", "name");
}

TEST_F(CbfApi, BadInputIsRefusedWithTheField) {
  const std::string s = new_session(c);
  // No session.
  expect_error(c.Post("/api/cbf/rollouts", R"({"scenario": "corridor"})", "application/json"), 401, "session_required");
  expect_error(post_rollout(c, s, {{"scenario", "nowhere"}}), 400, "invalid_input", "scenario");
  expect_error(post_rollout(c, s, {{"scenario", "../corridor"}}), 400, "invalid_input", "scenario");
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"metric", "manhattan"}}), 400, "invalid_input", "metric");
  expect_error(post_rollout(c, s, {{"metric", "gap"}}), 400, "invalid_input", "scenario");
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"params", {{"duraton", 1}}}}), 400, "invalid_input",
               "params.duraton");
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"params", {{"dt", -0.01}}}}), 400, "invalid_input",
               "params.dt");
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"params", {{"q0", {0, 0, 0, 0, 0, 0}}}}}), 400,
               "invalid_input", "params.q0");
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"params", {{"q0", {0, 0, 0, 0, 0, 0, 0}}}}}), 400,
               "invalid_input", "params.q0[3]");  // joint 4 must be in [-176°, -4°]
  // Not a finite number: NaN is not JSON, 1e999 overflows.
  expect_error(c.Post("/api/cbf/rollouts", session_headers(s), R"({"scenario": "corridor", "params": {"dt": NaN}})",
                      "application/json"),
               400, "malformed_json");
  expect_error(c.Post("/api/cbf/rollouts", session_headers(s), R"({"scenario": "corridor", "params": {"eta": 1e999}})",
                      "application/json"),
               400, "invalid_input", "params.eta");
  // Too long: over the codec's 600 s, and over the server's step budget.
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"params", {{"duration", 601}}}}), 400, "invalid_input",
               "params.duration");
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"params", {{"duration", 500}}}}), 422, "too_long",
               "params.duration");
  json tiny_dt = get_json(c, "", "/api/cbf/scenarios/corridor");
  tiny_dt["dt"] = 1e-4;
  expect_error(post_rollout(c, s, {{"scenario", tiny_dt}}), 422, "too_long", "scenario.duration");
  // Inline scenarios are checked as strictly, with their paths.
  json bad = get_json(c, "", "/api/cbf/scenarios/corridor");
  bad["obstacles"][1]["shape"]["size"][2] = -1;
  expect_error(post_rollout(c, s, {{"scenario", bad}}), 400, "invalid_input", "scenario.obstacles[1].shape.size[2]");
  bad = get_json(c, "", "/api/cbf/scenarios/corridor");
  bad["target"]["quaternion"] = {0, 0, 0, 0};
  expect_error(post_rollout(c, s, {{"scenario", bad}}), 400, "invalid_input", "scenario.target.quaternion");
  // Solver mode and velocity limits, in params and inline.
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"params", {{"gap", {{"mode", "published"}}}}}}), 400,
               "invalid_input", "params.gap.mode");
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"params", {{"gap", {{"mode", "as_published"}, {"max_iter", 0}}}}}}),
               400, "invalid_input", "params.gap.max_iter");
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"params", {{"velocity_limit", {1, 1, 1, 1, 1, 1}}}}}), 400,
               "invalid_input", "params.velocity_limit");
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"params", {{"velocity_limit", {1, 1, 1, 1, -1, 1, 1}}}}}),
               400, "invalid_input", "params.velocity_limit[4]");
  bad = get_json(c, "", "/api/cbf/scenarios/corridor_real");
  bad["velocity_limit"][6] = 0;
  expect_error(post_rollout(c, s, {{"scenario", bad}}), 400, "invalid_input", "scenario.velocity_limit[6]");
  bad = get_json(c, "", "/api/cbf/scenarios/corridor");
  bad["self_collision"] = "on";
  expect_error(post_rollout(c, s, {{"scenario", bad}}), 400, "invalid_input", "scenario.self_collision");
  // Stream options.
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"stream", {{"batch_steps", 0}}}}), 400, "invalid_input",
               "stream.batch_steps");
  expect_error(post_rollout(c, s, {{"scenario", "corridor"}, {"stream", {{"pairs", "yes"}}}}), 400, "invalid_input",
               "stream.pairs");
  expect_error(c.Post("/api/cbf/rollouts", session_headers(s), "[1, 2]", "application/json"), 400, "invalid_input");
  // Nothing was started.
  EXPECT_TRUE(get_json(c, s, "/api/cbf/rollouts")["rollouts"].empty());
  // Unknown rollouts and bad query parameters.
  expect_error(c.Get("/api/cbf/rollouts/0123", session_headers(s)), 404, "unknown_rollout");
  expect_error(c.Get("/api/cbf/rollouts/0123/record", session_headers(s)), 404, "unknown_rollout");
}

// GET /api/limits publishes the rollout limits (the same numbers as GET /api/cbf/scenarios) and
// names them in request_bounds; each is enforced at exactly its published value.
TEST_F(CbfApi, LimitsArePublishedAndEnforcedAtTheirValues) {
  const json limits = get_json(c, "", "/api/limits");
  const json published = get_json(c, "", "/api/cbf/scenarios")["limits"];
  EXPECT_EQ(limits["max_cbf_steps"], published["max_steps"]);
  EXPECT_EQ(limits["max_cbf_duration"], published["max_duration"]);
  EXPECT_EQ(limits["max_cbf_pair_steps"], published["max_pair_steps"]);
  EXPECT_EQ(limits["max_cbf_batch_steps"], published["max_batch_steps"]);
  EXPECT_EQ(limits["max_cbf_frames_per_request"], published["max_frames_per_request"]);
  EXPECT_EQ(limits["cbf_rollouts_kept_per_session"], published["kept_per_session"]);
  EXPECT_EQ(limits["max_cbf_sweep_values"], published["max_sweep_values"]);
  EXPECT_GE(limits["cbf_rollouts_kept_total"].get<long>(), limits["cbf_rollouts_kept_per_session"].get<long>());
  const json& bounds = limits["request_bounds"];
  auto names = [&](const char* route) {
    std::set<std::string> out;
    for (const json& n : bounds[route]) out.insert(n.get<std::string>());
    return out;
  };
  const std::set<std::string> post = names("POST /api/cbf/rollouts");
  for (const char* n : {"max_body_bytes", "max_cbf_steps", "max_cbf_duration", "max_cbf_pair_steps", "max_cbf_batch_steps",
                        "max_jobs_per_session", "max_jobs_total", "max_job_seconds", "cbf_rollouts_kept_per_session",
                        "cbf_rollouts_kept_total"})
    EXPECT_TRUE(post.count(n)) << n;
  EXPECT_TRUE(names("GET /api/cbf/rollouts/{id}/frames").count("max_cbf_frames_per_request"));
  EXPECT_TRUE(names("POST /api/cbf/sweeps").count("max_cbf_sweep_values"));
  EXPECT_TRUE(names("GET /api/cbf/rollouts/{id}/record").count("max_cbf_pair_steps"));

  // An inline corridor without self-collision: pairs = robot primitives × obstacles, known here.
  json sc = get_json(c, "", "/api/cbf/scenarios/corridor");
  sc["self_collision"] = false;
  const double dt = sc["dt"];
  const long max_steps = limits["max_cbf_steps"], max_pair_steps = limits["max_cbf_pair_steps"];
  const long primitives = static_cast<long>(get_json(c, "", "/api/cbf/robot")["primitives"].size());
  auto with = [&](json scenario, double duration) {
    scenario["duration"] = duration;
    return json{{"scenario", scenario}, {"metric", "euclidean"}};
  };
  auto accepted_then_cancelled = [&](const json& body) {
    const std::string s = new_session(c);
    auto r = post_rollout(c, s, body);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 202) << r->body;
    EXPECT_EQ(c.Delete("/api/session", session_headers(s))->status, 204);  // cancels the rollout
  };
  const std::string s = new_session(c);
  // Steps: max_cbf_steps is accepted, one more is 422 (pairs × steps stays under its own budget).
  json one = sc;
  one["obstacles"] = json::array({sc["obstacles"][0]});
  ASSERT_LT(primitives * (max_steps + 1), max_pair_steps) << "the step limit must be the one that binds here";
  accepted_then_cancelled(with(one, max_steps * dt));
  expect_error(post_rollout(c, s, with(one, (max_steps + 1) * dt)), 422, "too_long", "scenario.duration");
  // Pair-steps: four copies of the corridor's obstacles; the most steps that fit, then one more.
  json many = sc;
  many["obstacles"] = json::array();
  for (int copy = 0; copy < 4; ++copy)
    for (json o : sc["obstacles"]) {
      o["name"] = o["name"].get<std::string>() + "_" + std::to_string(copy);
      many["obstacles"].push_back(o);
    }
  const long pairs = primitives * static_cast<long>(many["obstacles"].size());
  const long fit = max_pair_steps / pairs;
  ASSERT_LT(fit + 1, max_steps) << "the pair-step limit must be the one that binds here";
  accepted_then_cancelled(with(many, fit * dt));
  auto r = post_rollout(c, s, with(many, (fit + 1) * dt));
  expect_error(r, 422, "too_long", "scenario.duration");
  EXPECT_NE(body_json(r)["error"]["message"].get<std::string>().find(std::to_string(max_pair_steps)), std::string::npos);
  // Stream batches: the published maximum is accepted, one more is 400 with the field.
  const int max_batch = limits["max_cbf_batch_steps"];
  json tiny = with(one, 2 * dt);
  tiny["stream"] = {{"batch_steps", max_batch + 1}};
  expect_error(post_rollout(c, s, tiny), 400, "invalid_input", "stream.batch_steps");
  tiny["stream"] = {{"batch_steps", max_batch}};
  accepted_then_cancelled(tiny);
  EXPECT_TRUE(get_json(c, s, "/api/cbf/rollouts")["rollouts"].empty()) << "refused requests start nothing";
}

TEST_F(CbfApi, FramesStreamAndMatchTheRecordAndTheRobotModel) {
  const std::string s = new_session(c);
  auto ws_owner = connect(server_->port(), s);
  WsClient& ws = *ws_owner;
  const json body = {{"scenario", "corridor"}, {"metric", "gap"}, {"params", {{"duration", 1.0}}}, {"stream", {{"batch_steps", 10}}}};
  const std::string id = start(c, s, body);
  std::map<std::size_t, json> frames;
  int messages = 0;
  ASSERT_EQ(follow(ws, id, frames, &messages), "succeeded");
  const json status = get_json(c, s, "/api/cbf/rollouts/" + id);
  EXPECT_EQ(status["state"], "finished");
  EXPECT_EQ(status["steps_total"], 100);
  EXPECT_EQ(status["steps_done"], 100);
  EXPECT_EQ(status["job"]["state"], "succeeded");
  EXPECT_EQ(status["obstacles"].size(), 3u);
  const std::size_t n_pairs = status["pairs"].size();
  EXPECT_EQ(n_pairs, 9u * 3u + 25u);
  // Every step exactly once, in batches of at most 10.
  ASSERT_EQ(frames.size(), 100u);
  EXPECT_EQ(frames.rbegin()->first, 99u);
  EXPECT_GE(messages, 10);

  const json rec = get_json(c, s, "/api/cbf/rollouts/" + id + "/record");
  ASSERT_EQ(rec["steps"], 100);
  for (std::size_t i = 0; i < 100; ++i) {
    const json& f = frames[i];
    EXPECT_EQ(f["t"], rec["t"][i]);
    EXPECT_EQ(f["q"], rec["q"][i]);
    EXPECT_EQ(f["u"], rec["u"][i]);
    EXPECT_EQ(f["task_error"], rec["task_error"][i]);
    EXPECT_EQ(f["min_distance"], rec["min_distance"][i]);
    ASSERT_EQ(f["distance"].size(), n_pairs);
    EXPECT_EQ(f["distance"], rec["distance"][i]);
    EXPECT_EQ(f["witness_a"], rec["witness_a"][i]);
    EXPECT_EQ(f["witness_b"], rec["witness_b"][i]);
    // min_distance is the smallest true clearance over the pairs.
    double smallest = INFINITY;
    for (const json& cl : f["clearance"]) smallest = std::min(smallest, cl.get<double>());
    EXPECT_EQ(smallest, f["min_distance"].get<double>());
    ASSERT_EQ(f["poses"].size(), 9u);
  }

  // The streamed primitive poses follow from q and GET /api/cbf/robot alone (its URDF joints).
  const json robot = get_json(c, "", "/api/cbf/robot");
  for (std::size_t i : {0ul, 57ul, 99ul}) {
    const json& f = frames[i];
    std::vector<Eigen::Isometry3d> T(robot["links"].size(), Eigen::Isometry3d::Identity());
    for (const json& jt : robot["joints"]) {
      const json& o = jt["origin"];
      Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();
      origin.translate(Eigen::Vector3d(o["position"][0], o["position"][1], o["position"][2]));
      origin.rotate(Eigen::Quaterniond(o["quaternion"][0], o["quaternion"][1], o["quaternion"][2], o["quaternion"][3]));
      Eigen::Isometry3d t = T[jt["parent"].get<int>()] * origin;
      if (jt["q"].get<int>() >= 0)
        t = t * Eigen::AngleAxisd(f["q"][jt["q"].get<int>()].get<double>(),
                                  Eigen::Vector3d(jt["axis"][0], jt["axis"][1], jt["axis"][2]));
      T[jt["child"].get<int>()] = t;
    }
    for (std::size_t p = 0; p < 9; ++p) {
      const json& prim = robot["primitives"][p];
      const json& pos = prim["pose"]["position"];
      const json& qu = prim["pose"]["quaternion"];
      Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
      local.translate(Eigen::Vector3d(pos[0], pos[1], pos[2]));
      local.rotate(Eigen::Quaterniond(qu[0], qu[1], qu[2], qu[3]));
      const Eigen::Isometry3d world = T[prim["link"].get<int>()] * local;
      const json& got = f["poses"][p];
      const Eigen::Quaterniond gq(got[3], got[4], got[5], got[6]);
      EXPECT_LT((world.translation() - Eigen::Vector3d(got[0], got[1], got[2])).norm(), 1e-12) << i << " " << p;
      EXPECT_LT(gq.angularDistance(Eigen::Quaterniond(world.rotation())), 1e-9) << i << " " << p;
    }
  }

  // Smoothness per joint, as the record defines it.
  ASSERT_EQ(rec["smoothness"]["total_variation"].size(), 7u);
  for (int j = 0; j < 7; ++j) {
    double tv = 0, rate = 0;
    for (std::size_t i = 1; i < 100; ++i) {
      const double du = std::abs(rec["u"][i][j].get<double>() - rec["u"][i - 1][j].get<double>());
      tv += du;
      rate = std::max(rate, du / rec["dt"].get<double>());
    }
    EXPECT_NEAR(rec["smoothness"]["total_variation"][j].get<double>(), tv, 1e-12 * (1 + tv));
    EXPECT_NEAR(rec["smoothness"]["max_rate"][j].get<double>(), rate, 1e-12 * (1 + rate));
  }

  // Frames by REST, and replayed to a late joiner over the WebSocket.
  const json part = get_json(c, s, "/api/cbf/rollouts/" + id + "/frames?from=50&count=10");
  ASSERT_EQ(part["frames"].size(), 10u);
  EXPECT_EQ(part["first"], 50);
  EXPECT_EQ(part["frames"][0], frames[50]);
  EXPECT_EQ(part["frames"][9], frames[59]);
  EXPECT_EQ(get_json(c, s, "/api/cbf/rollouts/" + id + "/frames?from=1000")["frames"].size(), 0u);
  expect_error(c.Get(("/api/cbf/rollouts/" + id + "/frames?from=-1"), session_headers(s)), 400, "invalid_input", "from");
  expect_error(c.Get(("/api/cbf/rollouts/" + id + "/frames?count=999999"), session_headers(s)), 413, "too_many_frames", "count");

  auto late_owner = connect(server_->port(), s);
  WsClient& late = *late_owner;
  late.send({{"type", "cbf_replay"}, {"rollout", id}, {"from", 0}});
  std::map<std::size_t, json> replayed;
  Msg m;
  ASSERT_TRUE(late.until(
      [&](const Msg& x) {
        if (x.binary || x.j["type"] != "cbf_frames") return false;
        for (const json& f : x.j["frames"]) replayed[f["i"].get<std::size_t>()] = f;
        return replayed.size() == 100;
      },
      m, 60));
  EXPECT_EQ(replayed, frames);
  late.send({{"type", "cbf_replay"}, {"rollout", "0123"}});
  ASSERT_TRUE(late.until([](const Msg& x) { return !x.binary && x.j["type"] == "error"; }, m, 30));
  EXPECT_EQ(m.j["status"], 404);
  EXPECT_EQ(m.j["error"]["code"], "unknown_rollout");

  // Without pairs and poses the frames are small.
  const std::string lean = start(c, s, {{"scenario", "corridor"}, {"metric", "euclidean"}, {"params", {{"duration", 0.2}}}, {"stream", {{"pairs", false}, {"poses", false}}}});
  std::map<std::size_t, json> lean_frames;
  ASSERT_EQ(follow(ws, lean, lean_frames), "succeeded");
  ASSERT_EQ(lean_frames.size(), 20u);
  EXPECT_FALSE(lean_frames[0].contains("poses"));
  EXPECT_FALSE(lean_frames[0].contains("distance"));
  EXPECT_TRUE(lean_frames[0]["q"].is_array());
  EXPECT_EQ(get_json(c, s, "/api/cbf/rollouts")["rollouts"].size(), 2u);
}

TEST_F(CbfApi, RecordIsTheCliRecord) {
  const std::string s = new_session(c);
  auto ws_owner = connect(server_->port(), s);
  WsClient& ws = *ws_owner;
  json inline_scenario = get_json(c, "", "/api/cbf/scenarios/corridor");
  inline_scenario["name"] = "corridor-inline";
  inline_scenario["obstacles"][2]["shape"]["pose"]["position"][2] = 0.95;
  const json requests[] = {
      {{"scenario", "corridor"}, {"metric", "gap"}, {"params", {{"duration", 0.6}}}},
      {{"scenario", "corridor"}, {"metric", "euclidean"}, {"params", {{"duration", 0.6}, {"record_pairs", false}}}},
      {{"scenario", inline_scenario}, {"metric", "euclidean"}, {"params", {{"duration", 0.3}, {"audit", false}}}},
  };
  for (const json& request : requests) {
    const std::string id = start(c, s, request);
    std::map<std::size_t, json> frames;
    ASSERT_EQ(follow(ws, id, frames), "succeeded");
    json api = get_json(c, s, "/api/cbf/rollouts/" + id + "/record");
    json cli = run_cli(request);
    ASSERT_TRUE(cli.is_object() && cli.contains("q")) << cli.dump().substr(0, 300);
    // Timings differ from run to run; every other number is the same.
    EXPECT_TRUE(api["timing"].contains("step_us_mean"));
    api.erase("timing");
    cli.erase("timing");
    EXPECT_EQ(api.contains("distance"), request["params"].value("record_pairs", true));
    for (const auto& [key, value] : cli.items()) EXPECT_EQ(api[key], value) << "record field " << key << " of " << request;
    EXPECT_EQ(api.size(), cli.size());
  }
}

TEST_F(CbfApi, CancelMidwayAndOtherSessionsSeeNothing) {
  const std::string s = new_session(c), other = new_session(c);
  auto ws_owner = connect(server_->port(), s), spy_owner = connect(server_->port(), other);
  WsClient &ws = *ws_owner, &spy = *spy_owner;
  // 150 s of simulated time: seconds of work, so it is cancelled while running.
  const std::string id = start(c, s, {{"scenario", "corridor"}, {"metric", "gap"}, {"params", {{"duration", 150}, {"record_pairs", false}}}, {"stream", {{"batch_steps", 20}, {"pairs", false}}}});
  expect_error(c.Get(("/api/cbf/rollouts/" + id + "/record"), session_headers(s)), 409, "not_finished");

  // Another session: 404 everywhere, and no frames on its socket.
  expect_error(c.Get(("/api/cbf/rollouts/" + id), session_headers(other)), 404, "unknown_rollout");
  expect_error(c.Get(("/api/cbf/rollouts/" + id + "/frames"), session_headers(other)), 404, "unknown_rollout");
  expect_error(c.Get(("/api/cbf/rollouts/" + id + "/record"), session_headers(other)), 404, "unknown_rollout");
  expect_error(c.Post(("/api/jobs/" + id + "/cancel"), session_headers(other), "", "application/json"), 404, "unknown_job");
  EXPECT_TRUE(get_json(c, other, "/api/cbf/rollouts")["rollouts"].empty());
  spy.send({{"type", "cbf_replay"}, {"rollout", id}});
  Msg m;
  ASSERT_TRUE(spy.until([](const Msg& x) { return !x.binary; }, m, 30));
  EXPECT_EQ(m.j["type"], "error") << m.data;
  EXPECT_EQ(m.j["error"]["code"], "unknown_rollout");

  std::map<std::size_t, json> frames;
  bool cancel_sent = false;
  const std::string state = follow(ws, id, frames, nullptr, [&](const json& msg) {
    if (cancel_sent || msg["steps_done"].get<int>() < 100) return;
    cancel_sent = cancel_job(c, s, id);
  });
  EXPECT_TRUE(cancel_sent);
  EXPECT_EQ(state, "cancelled");
  const json status = get_json(c, s, "/api/cbf/rollouts/" + id);
  EXPECT_EQ(status["state"], "cancelled");
  EXPECT_EQ(status["job"]["error"]["code"], "cancelled");
  // The cancelled job keeps the steps so far as its result (the rollout and its summary).
  EXPECT_EQ(status["job"]["result"]["rollout"], id) << status.dump();
  EXPECT_EQ(status["job"]["result"]["summary"]["steps"], status["steps_done"]) << status.dump();
  const int done = status["steps_done"];
  EXPECT_GE(done, 100);
  EXPECT_LT(done, 15000);
  EXPECT_EQ(frames.size(), static_cast<std::size_t>(done)) << "every computed step was streamed";
  // The partial record is kept and says so.
  const json rec = get_json(c, s, "/api/cbf/rollouts/" + id + "/record");
  EXPECT_EQ(rec["steps"], done);
  EXPECT_EQ(rec["summary"]["cancelled"], true);
  EXPECT_EQ(rec["summary"]["reached"], false);
  // The other session's socket saw none of it.
  while (spy.read(m, 0.2)) EXPECT_NE(m.j["type"], "cbf_frames");
}

// Reads WebSocket messages until the job `id` ends; collects its progress events.
std::string follow_job(WsClient& ws, const std::string& id, std::vector<json>& progress,
                       const std::function<void(const json&)>& on_progress = {}) {
  Msg m;
  std::string final_state;
  const bool ok = ws.until(
      [&](const Msg& x) {
        if (x.binary || x.j["type"] != "job" || x.j["job"]["id"] != id) return false;
        const std::string st = x.j["job"]["state"];
        if (st == "succeeded" || st == "failed" || st == "cancelled") final_state = st;
        else {
          progress.push_back(x.j["job"]);
          if (on_progress) on_progress(x.j["job"]);
        }
        return !final_state.empty();
      },
      m, 300);
  EXPECT_TRUE(ok) << "no final job event for " << id;
  return final_state;
}

// A sweep of the GAP obstacle margin over the first 5 s of the published corridor: one job with
// progress, each entry exactly the record of the single run with that margin (`distlab cbf`, bit
// for bit: JSON numbers round-trip); `distlab cbf` with the same "sweep" gives the same entries.
// The margins' outcomes over the whole 35 s are test_corridor_outcomes.cpp's (six runs of 35 s
// here took 160 s under ASan).
TEST_F(CbfApi, SweepEntriesAreTheSingleRuns) {
  const std::string s = new_session(c);
  auto ws_owner = connect(server_->port(), s);
  const json values = {0.002, 0.0002};
  const json request = {{"scenario", "corridor"},
                        {"metric", "gap"},
                        {"params", {{"duration", 5}}},
                        {"sweep", {{"parameter", "margins.gap.obstacle"}, {"values", values}}}};
  auto r = c.Post("/api/cbf/sweeps", session_headers(s), request.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const json posted = body_json(r);
  const std::string id = posted["sweep"]["id"];
  EXPECT_EQ(posted["job"]["id"], id);
  EXPECT_EQ(posted["job"]["kind"], "cbf_sweep");
  std::vector<json> progress;
  ASSERT_EQ(follow_job(*ws_owner, id, progress), "succeeded");
  double last = 0;
  std::set<std::string> stages;
  for (const json& p : progress) {
    if (!p.contains("fraction")) continue;
    EXPECT_GE(p["fraction"].get<double>(), last);
    last = p["fraction"];
    stages.insert(p.value("stage", ""));
  }
  EXPECT_TRUE(stages.count("1 of 2 runs done")) << json(progress).dump().substr(0, 400);

  const json sweep = get_json(c, s, "/api/cbf/sweeps/" + id);
  EXPECT_EQ(sweep["job"]["state"], "succeeded");
  EXPECT_EQ(sweep["parameter"], "margins.gap.obstacle");
  EXPECT_EQ(sweep["values"], values);
  ASSERT_EQ(sweep["entries"].size(), 2u);
  for (std::size_t i = 0; i < values.size(); ++i) {
    const json& e = sweep["entries"][i];
    EXPECT_EQ(e["index"], i);
    EXPECT_EQ(e["value"], values[i]);
    // The single run, written out independently of the sweep's own request building.
    const json single = {{"scenario", "corridor"}, {"metric", "gap"}, {"params", {{"duration", 5}, {"margins", {{"gap", {{"obstacle", values[i]}}}}}, {"audit", true}}}};
    const json rec = run_cli(single);
    ASSERT_TRUE(rec.contains("summary")) << rec.dump().substr(0, 300);
    EXPECT_EQ(e["summary"], rec["summary"]) << "value " << values[i];
    EXPECT_EQ(e["smoothness"], rec["smoothness"]);
    EXPECT_EQ(e["gap_mode"], rec["gap_mode"]);
    EXPECT_EQ(e["steps"], rec["steps"]);
    EXPECT_EQ(e["infeasible_steps"], rec["infeasible_steps"].size());
    EXPECT_EQ(e["position_error"], rec["summary"]["final"]["position_error"]);
    EXPECT_EQ(e["min_clearance"], rec["summary"]["min_distance"]);
    double tv = 0;
    for (const json& v : rec["smoothness"]["total_variation"]) tv += v.get<double>();
    EXPECT_EQ(e["total_variation"].get<double>(), tv);
  }
  EXPECT_EQ(sweep["entries"][0]["steps"], 500);  // dt 0.01 over 5 s
  EXPECT_NE(sweep["entries"][0]["position_error"], sweep["entries"][1]["position_error"]);
  for (const json& e : sweep["entries"]) EXPECT_GT(e["min_clearance"].get<double>(), 0.0);

  json cli = run_cli(request);
  ASSERT_TRUE(cli.contains("entries")) << cli.dump().substr(0, 300);
  json api_entries = sweep["entries"];
  for (json* list : {&cli["entries"], &api_entries})
    for (json& e : *list) e.erase("step_us_mean");  // a timing
  EXPECT_EQ(cli["entries"], api_entries);
  EXPECT_EQ(cli["parameter"], "margins.gap.obstacle");
}

// Bad sweeps are refused before any job, naming the field; a running sweep cancels with the
// job vocabulary and keeps the runs it finished; another session sees nothing.
TEST_F(CbfApi, SweepRefusalsAndCancel) {
  const std::string s = new_session(c), other = new_session(c);
  auto post = [&](const json& body) { return c.Post("/api/cbf/sweeps", session_headers(s), body.dump(), "application/json"); };
  const json base = {{"scenario", "corridor"}, {"metric", "gap"}};
  auto with = [&](const json& sweep) {
    json b = base;
    b["sweep"] = sweep;
    return b;
  };
  expect_error(post(base), 400, "invalid_input", "sweep");
  expect_error(post(with({{"parameter", "task_gain"}})), 400, "invalid_input", "sweep.values");
  expect_error(post(with({{"parameter", "task_gain"}, {"values", json::array()}})), 400, "invalid_input", "sweep.values");
  json many = json::array();
  for (int i = 0; i <= 16; ++i) many.push_back(0.1 + 0.01 * i);
  expect_error(post(with({{"parameter", "task_gain"}, {"values", many}})), 400, "invalid_input", "sweep.values");
  expect_error(post(with({{"parameter", "task_gain"}, {"values", {0.4}}, {"steps", 3}})), 400, "invalid_input", "sweep.steps");
  expect_error(post(with({{"parameter", "no_such_setting"}, {"values", {1}}})), 400, "invalid_input", "sweep.parameter");
  expect_error(post(with({{"parameter", "margins.gap.nope"}, {"values", {1}}})), 400, "invalid_input", "sweep.parameter");
  expect_error(post(with({{"parameter", "audit"}, {"values", {false}}})), 400, "invalid_input", "sweep.parameter");
  expect_error(post(with({{"parameter", "margins.gap.obstacle"}, {"values", {0.002, -1}}})), 400, "invalid_input",
               "sweep.values[1]");
  expect_error(post(with({{"parameter", "duration"}, {"values", {1, 1e5}}})), 400, "invalid_input", "sweep.values[1]");

  auto ws_owner = connect(server_->port(), s);
  // A short run, then two 150 s ones (in parallel on the compute pool): seconds of work,
  // cancelled once the short one finished.
  json body = with({{"parameter", "duration"}, {"values", {0.2, 150, 150}}});
  body["params"] = {{"record_pairs", false}};
  auto r = post(body);
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string id = body_json(r)["sweep"]["id"];
  expect_error(c.Get(("/api/cbf/sweeps/" + id), session_headers(other)), 404, "unknown_sweep");
  expect_error(c.Post(("/api/jobs/" + id + "/cancel"), session_headers(other), "", "application/json"), 404, "unknown_job");
  std::vector<json> progress;
  bool cancel_sent = false;
  const std::string state = follow_job(*ws_owner, id, progress, [&](const json& job) {
    if (cancel_sent || job.value("stage", "") != "1 of 3 runs done" || job.value("fraction", 0.0) < 0.05) return;
    cancel_sent = cancel_job(c, s, id);
  });
  EXPECT_TRUE(cancel_sent);
  EXPECT_EQ(state, "cancelled");
  const json sweep = get_json(c, s, "/api/cbf/sweeps/" + id);
  EXPECT_EQ(sweep["job"]["state"], "cancelled");
  ASSERT_EQ(sweep["entries"].size(), 1u) << "the finished first run is kept, the cancelled one is not";
  EXPECT_EQ(sweep["entries"][0]["value"], 0.2);
  EXPECT_EQ(sweep["entries"][0]["steps"], 20);
}

}  // namespace
// POST /api/cbf/feasibility is `distlab cbf --feasibility`: the same numbers for the same request.
TEST_F(CbfApi, TargetFeasibilityIsTheCliAnswer) {
  const json request = {{"scenario", "corridor_narrow"}};
  const auto r = c.Post("/api/cbf/feasibility", request.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const json api = json::parse(r->body);
  EXPECT_TRUE(api["reachable"].get<bool>());
  EXPECT_FALSE(api["euclidean_feasible"].get<bool>());
  EXPECT_EQ(api["q"].size(), 7u);
  EXPECT_EQ(api, run_cli(request, {"--feasibility"}));
  expect_error(c.Post("/api/cbf/feasibility", R"({"scenario": "nowhere"})", "application/json"), 400, "invalid_input",
               "scenario");
}

}  // namespace distlab::test
