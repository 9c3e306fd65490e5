// What a Kelvin preparation will make and take, said before it runs (issue 37 item 3): the
// server's predicted field vertices are within 1.5× of what the preparation makes, for the
// project's Kelvin assets at the view's own l_x and for three real meshes of Debian's
// assimp-testmodels uploaded and wrapped (their wrap makes the surface: the job predicts on it
// before it prepares); the time is those vertices at this server's seconds per vertex, a default
// before its first preparation and measured over the ones it computed afterwards.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "server/server_fixture.hpp"

namespace distlab::test {
namespace {

class Estimates : public SharedServerTest<Estimates> {
 protected:
  std::string s = new_session(c);
  httplib::Headers h = session_headers(s);

  json post(const std::string& path, const json& body, int status) {
    auto r = c.Post(path, h, body.dump(), "application/json");
    EXPECT_TRUE(r) << "no answer: the server died";
    if (!r) return json();
    EXPECT_EQ(r->status, status) << path << ": " << r->body;
    return body_json(r);
  }
  // Polls an object until it leaves repairing/preparing (bounded); its status.
  json settle(const std::string& id) {
    json st;
    for (int i = 0; i < 3000; ++i) {  // 300 s (a wrap under the sanitizers)
      st = get_json(c, s, "/api/kelvin/objects/" + id);
      if (st["state"] != "preparing" && st["state"] != "repairing") break;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return st;
  }
  // The predicted vertices of an estimate (today's server had only vertex_estimate, the budget's
  // closed form, and showed that as the expected count).
  static double predicted(const json& e) {
    const json& p = e.contains("vertices_predicted") ? e["vertices_predicted"] : e["vertex_estimate"];
    return p.is_number() ? p.get<double>() : std::nan("");
  }
};

// The machine's load over the last minute (/proc/loadavg), beside the times printed.
std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string one;
  in >> one;
  return one;
}

std::string three_digits(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", x);
  return text;
}

// Checks the vertices; prints them with the estimate's seconds (at the rate it names) against the
// preparation's (stats.t_prepare), which are not checked: they depend on the machine's load.
void expect_within(double predicted, double made, const std::string& what, const json& estimate = nullptr, const json& stats = nullptr) {
  const double ratio = predicted / made;
  std::string times = "| | | |";
  if (estimate.is_object() && estimate["seconds_estimate"].is_number() && stats.is_object()) {
    const json& rate = estimate["seconds_per_vertex"];
    times = "| " + json(std::round(estimate["seconds_estimate"].get<double>() * 10) / 10).dump() + " (" + rate["source"].get<std::string>() + ", " +
            rate["preparations"].dump() + ") | " + json(std::round(stats.value("t_prepare", 0.0) * 10) / 10).dump() + " | " + load_average() + " |";
  }
  std::printf("| %s | %.0f | %.0f | %.2f %s\n", what.c_str(), predicted, made, ratio, times.c_str());
  EXPECT_TRUE(ratio >= 1 / 1.5 && ratio <= 1.5) << what << ": predicted " << predicted << " field vertices, the preparation made " << made;
}

// The time is the predicted vertices at the server's seconds per vertex, whose source says what it is.
void expect_time(const json& e, std::size_t preparations) {
  const json& rate = e["seconds_per_vertex"];
  EXPECT_EQ(rate["source"], preparations == 0 ? "default" : "measured") << e.dump();
  EXPECT_EQ(rate["preparations"], std::min<std::size_t>(preparations, 16)) << e.dump();
  EXPECT_GT(rate["value"].get<double>(), 0);
  EXPECT_DOUBLE_EQ(e["seconds_estimate"].get<double>(), e["vertices_predicted"].get<double>() * rate["value"].get<double>()) << e.dump();
}

// The view's built-in objects at its own l_x (web/src/views/kelvin/kelvin_state.ts: defaultLx):
// the estimate before, the job's own estimate (the same: one prediction per request), what it made.
TEST_F(Estimates, TheAssetsFieldVerticesAreWithinOneAndAHalfTimesThePrediction) {
  std::printf("| object | predicted vertices | made | ratio | predicted s (rate: source, preparations) | t_prepare s | load |\n|---|---|---|---|---|---|---|\n");
  std::size_t computed = 0;
  for (const auto& [asset, lx] : std::vector<std::pair<std::string, double>>{{"cube", 0.1}, {"sphere", 0.1}, {"knife", 0.05}, {"wrench", 0.005}}) {
    SCOPED_TRACE(asset);
    const json body = {{"asset", asset}, {"lx", lx}};
    const json e = post("/api/kelvin/estimate", body, 200);
    ASSERT_TRUE(e["problem"].is_null()) << e.dump();
    // Asked again, the same answer (nothing was prepared in between).
    EXPECT_EQ(post("/api/kelvin/estimate", body, 200), e);
    const json created = post("/api/kelvin/objects", body, 202);
    const json st = settle(created["object"]["id"]);
    ASSERT_EQ(st["state"], "ready") << st.dump();
    expect_within(predicted(e), st["stats"]["n_verts"].get<double>(), asset + " at l_x " + json(lx).dump(), e, st["stats"]);
    ASSERT_TRUE(e.contains("seconds_per_vertex")) << "no seconds per vertex: " << e.dump();
    expect_time(e, computed);
    ++computed;
    ASSERT_TRUE(st.contains("estimate")) << st.dump();
    EXPECT_EQ(st["estimate"]["vertices_predicted"], e["vertices_predicted"]) << "one prediction per request";
    EXPECT_EQ(st["estimate"]["grading"], st["stats"]["grading"]) << "the sizing predicted is the sizing meshed";
    EXPECT_GT(st["stats"]["t_prepare"].get<double>(), 0);
  }
  // The rate is what the preparations took per vertex (the last 16; here all of them).
  const json after = post("/api/kelvin/estimate", {{"asset", "cube"}, {"lx", 0.1}}, 200);
  expect_time(after, computed);
}

// Three real meshes as users upload them (assimp-testmodels: none is a closed 2-manifold), wrapped
// at the default α and prepared at a l_x of a twentieth of their diagonal: the estimate cannot
// know the wrap's surface and says so; the job predicts on it before it prepares.
TEST_F(Estimates, WrappedUploadsFieldVerticesAreWithinOneAndAHalfTimesThePrediction) {
  const fs::path root = "/usr/share/assimp/models";
  if (!fs::is_directory(root)) GTEST_SKIP() << "assimp-testmodels is not installed (.ci/packages.txt)";
  std::printf("| upload (wrap) | predicted vertices | made | ratio | predicted s (rate: source, preparations) | t_prepare s | load |\n|---|---|---|---|---|---|---|\n");
  for (const auto& [file, format] : std::vector<std::pair<std::string, std::string>>{
           {"STL/Wuson.stl", "stl"}, {"OBJ/spider.obj", "obj"}, {"STL/3DSMaxExport.STL", "stl"}}) {
    SCOPED_TRACE(file);
    std::ifstream in(root / file, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), {});
    auto r = c.Post("/api/kelvin/uploads?format=" + format, h, bytes, "application/octet-stream");
    ASSERT_TRUE(r && r->status == 201) << (r ? r->body : "no answer");
    const json up = body_json(r);
    const json body = {{"upload", up["upload"]}, {"lx_fraction", 0.05}, {"repair", "wrap"}};
    const json e = post("/api/kelvin/estimate", body, 200);
    ASSERT_TRUE(e["problem"].is_null()) << e.dump();
    const json st = settle(post("/api/kelvin/objects", body, 202)["object"]["id"]);
    ASSERT_EQ(st["state"], "ready") << st.dump();
    // Today's server had no prediction of its own: its estimate was the budget's closed form.
    const json job = st.contains("estimate") ? st["estimate"] : e;
    expect_within(predicted(job), st["stats"]["n_verts"].get<double>(), file + " at l_x " + three_digits(st["source"]["lx"]), job, st["stats"]);
    EXPECT_TRUE(e["vertices_predicted"].is_null()) << e.dump();
    EXPECT_TRUE(e["prediction_note"].is_string()) << e.dump();
    EXPECT_EQ(job["grading"], st["stats"]["grading"]);
    c.Delete("/api/kelvin/objects/" + st["id"].get<std::string>(), h);
  }
}

}  // namespace
}  // namespace distlab::test
