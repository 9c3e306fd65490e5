// End-to-end tests of `distlab gap`: the real executable, fed on stdin, checked on stdout,
// stderr and the exit code.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli/run_process.hpp"
#include "distlab/gap/distance.hpp"
#include "distlab/server/gap_json.hpp"

extern char** environ;

namespace {

using nlohmann::json;

struct CliRun {
  int code = -1;
  std::string out, err;
  json body() const { return json::parse(out); }
};

// Temporary files, not pipes: no deadlock however much either side writes, and the max_body_bytes test
// needs no writer thread.
std::string temp_file(const std::string& content) {
  char path[] = "/tmp/distlab_cli_XXXXXX";
  const int fd = mkstemp(path);
  if (fd < 0) throw std::runtime_error("mkstemp failed");
  std::size_t done = 0;
  while (done < content.size()) {
    const ssize_t n = write(fd, content.data() + done, content.size() - done);
    if (n <= 0) throw std::runtime_error("write failed");
    done += static_cast<std::size_t>(n);
  }
  close(fd);
  return path;
}

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

CliRun run_distlab(const std::string& input, std::vector<std::string> args = {}) {
  const std::string in = temp_file(input), out = temp_file(""), err = temp_file("");
  args.insert(args.begin(), {DISTLAB_EXE, "gap"});
  CliRun r;
  r.code = distlab::test::run_process(args, in, out, err);
  r.out = slurp(out);
  r.err = slurp(err);
  for (const auto& p : {in, out, err}) std::remove(p.c_str());
  return r;
}

json box(double x, double y, double z, json position = {0, 0, 0}) {
  return {{"type", "box"}, {"size", {x, y, z}}, {"pose", {{"position", position}}}};
}

// A separated box and cylinder, the paper's parameters.
json example_pair() {
  return {{"a", box(0.4, 0.3, 0.2)},
          {"b",
           {{"type", "cylinder"},
            {"radius", 0.1},
            {"height", 0.5},
            {"pose",
             {{"position", {0.6, 0.05, 0.1}},
              {"quaternion", {0.9659258262890683, 0.0, 0.25881904510252074, 0.0}}}}}},
          {"params", {{"h", 0.1}, {"k", 2}, {"eps", 0.01}, {"sigma", 0.989}}}};
}

void expect_finite_numbers(const json& j, const std::string& where = "") {
  if (j.is_number()) {
    EXPECT_TRUE(std::isfinite(j.get<double>())) << where;
  } else if (j.is_structured()) {
    for (const auto& [k, v] : j.items()) expect_finite_numbers(v, where + "/" + k);
  }
}

void expect_vec(const json& j, std::size_t n, const std::string& name) {
  ASSERT_TRUE(j.is_array()) << name;
  ASSERT_EQ(j.size(), n) << name;
  for (const auto& x : j) EXPECT_TRUE(x.is_number()) << name;
}

// Exit code, error code and field of a refused request; stdout is the JSON error body and
// stderr a single line.
void expect_error(const CliRun& r, int code, const std::string& error_code,
                  const std::string& field) {
  EXPECT_EQ(r.code, code) << r.out << r.err;
  json b;
  ASSERT_NO_THROW(b = r.body()) << r.out;
  ASSERT_TRUE(b.contains("error")) << r.out;
  EXPECT_EQ(b["error"]["code"], error_code) << r.out;
  EXPECT_EQ(b["error"]["field"], field) << r.out;
  EXPECT_TRUE(b["error"]["message"].is_string());
  EXPECT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
}

TEST(GapCli, PairGivesEveryFieldAndFiniteNumbers) {
  const CliRun r = run_distlab(example_pair().dump());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const json b = r.body();
  for (const char* key : {"lambda", "distance", "iterations"})
    EXPECT_TRUE(b[key].is_number()) << key;
  for (const char* key : {"converged", "overlap"}) EXPECT_TRUE(b[key].is_boolean()) << key;
  expect_vec(b["witness_a"], 3, "witness_a");
  expect_vec(b["witness_b"], 3, "witness_b");
  expect_vec(b["gradient_a"], 6, "gradient_a");  // gradient defaults to true
  expect_vec(b["gradient_b"], 6, "gradient_b");
  ASSERT_TRUE(b["euclidean"].is_object());
  EXPECT_TRUE(b["euclidean"]["distance"].is_number());
  expect_vec(b["euclidean"]["witness_a"], 3, "euclidean.witness_a");
  expect_vec(b["euclidean"]["witness_b"], 3, "euclidean.witness_b");
  expect_vec(b["euclidean"]["gradient_a"], 6, "euclidean.gradient_a");
  expect_vec(b["euclidean"]["gradient_b"], 6, "euclidean.gradient_b");
  for (const char* s : {"a", "b"}) {
    EXPECT_EQ(b["validation"][s]["ok"], true);
    EXPECT_LT(b["validation"][s]["max_eigenvalue"].get<double>(), 1.0);
    EXPECT_GT(b["validation"][s]["samples"].get<int>(), 0);
  }
  expect_finite_numbers(b);
  EXPECT_TRUE(r.err.empty()) << r.err;
  // Compact by default; --pretty indents the same document.
  EXPECT_EQ(r.out.find('\n'), r.out.size() - 1);
  const CliRun pretty = run_distlab(example_pair().dump(), {"--pretty"});
  ASSERT_EQ(pretty.code, 0);
  EXPECT_GT(std::count(pretty.out.begin(), pretty.out.end(), '\n'), 10);
  EXPECT_EQ(pretty.body(), b);
}

TEST(GapCli, NoGradientsWhenNotAsked) {
  json req = example_pair();
  req["params"]["gradient"] = false;
  req["params"]["validate"] = false;
  const CliRun r = run_distlab(req.dump());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const json b = r.body();
  EXPECT_FALSE(b.contains("gradient_a"));
  EXPECT_FALSE(b["euclidean"].contains("gradient_a"));
  EXPECT_FALSE(b.contains("validation"));
}

TEST(GapCli, SeparatedShapesHavePositiveDistance) {
  const CliRun r = run_distlab(example_pair().dump());
  ASSERT_EQ(r.code, 0) << r.err;
  const json b = r.body();
  EXPECT_FALSE(b["overlap"].get<bool>());
  EXPECT_TRUE(b["converged"].get<bool>());
  EXPECT_GT(b["lambda"].get<double>(), 0);
  EXPECT_GT(b["distance"].get<double>(), 0);
  EXPECT_NEAR(b["distance"].get<double>(), std::sqrt(2 * b["lambda"].get<double>()), 1e-15);
  EXPECT_GT(b["euclidean"]["distance"].get<double>(), 0);
}

TEST(GapCli, OverlapGivesZeroLambda) {
  const json req = {{"a", box(1, 1, 1)}, {"b", box(1, 1, 1, {0.5, 0.2, 0.1})}};
  const CliRun r = run_distlab(req.dump());
  ASSERT_EQ(r.code, 0) << r.err;
  const json b = r.body();
  EXPECT_TRUE(b["overlap"].get<bool>());
  EXPECT_EQ(b["lambda"].get<double>(), 0.0);
  EXPECT_EQ(b["distance"].get<double>(), 0.0);
  EXPECT_EQ(b["euclidean"]["distance"].get<double>(), 0.0);
  expect_finite_numbers(b);
}

TEST(GapCli, TwoBoxesMatchTheLibrary) {
  const double w = std::cos(0.3), s = std::sin(0.3);  // unit quaternion: same pose both ways
  json req = {{"a", box(0.5, 0.4, 0.3)}, {"b", box(0.2, 0.6, 0.25, {0.9, 0.3, -0.1})}};
  req["b"]["pose"]["quaternion"] = {w, 0.0, 0.0, s};
  const CliRun r = run_distlab(req.dump());
  ASSERT_EQ(r.code, 0) << r.err;
  const json b = r.body();

  const distlab::GapParams params;
  distlab::Pose pb;
  pb.position = distlab::Vec3(0.9, 0.3, -0.1);
  pb.rotation = distlab::Quat(w, 0, 0, s);
  const distlab::GapBody A(distlab::Box{distlab::Vec3(0.5, 0.4, 0.3)}, distlab::Pose{}, params);
  const distlab::GapBody B(distlab::Box{distlab::Vec3(0.2, 0.6, 0.25)}, pb, params);
  const distlab::GapResult lib = distlab::gap_distance(A, B, params);
  EXPECT_NEAR(b["distance"].get<double>(), lib.distance, 1e-14);
  EXPECT_NEAR(b["lambda"].get<double>(), lib.lambda, 1e-14);
  EXPECT_NEAR(b["euclidean"]["distance"].get<double>(), lib.euclidean.distance, 1e-14);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(b["witness_a"][i].get<double>(), lib.witness_a[i], 1e-14);
    EXPECT_NEAR(b["witness_b"][i].get<double>(), lib.witness_b[i], 1e-14);
  }
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(b["gradient_a"][i].get<double>(), lib.gradient_a[i], 1e-12);
    EXPECT_NEAR(b["gradient_b"][i].get<double>(), lib.gradient_b[i], 1e-12);
  }
  EXPECT_EQ(b["iterations"].get<int>(), lib.iterations);
}

// 50 pairs of boxes, cylinders, spheres and capsules in varied poses.
std::vector<json> fifty_pairs() {
  std::vector<json> pairs;
  const json shapes[] = {
      {{"type", "box"}, {"size", {0.3, 0.2, 0.4}}},
      {{"type", "cylinder"}, {"radius", 0.1}, {"height", 0.3}},
      {{"type", "sphere"}, {"radius", 0.15}},
      {{"type", "capsule"}, {"radius", 0.08}, {"height", 0.2}},
  };
  for (int i = 0; i < 50; ++i) {
    json a = shapes[i % 4], b = shapes[(i / 4) % 4];
    const double t = 0.37 * i;
    a["pose"] = {{"position", {0.01 * i, -0.02 * i, 0.0}},
                 {"quaternion", {std::cos(t), std::sin(t), 0.0, 0.0}}};
    b["pose"] = {
        {"position", {0.5 + 0.01 * i, 0.1 * std::sin(t), 0.05 * std::cos(t)}},
        {"quaternion", {std::cos(2 * t), 0.0, std::sin(2 * t) * 0.6, std::sin(2 * t) * 0.8}}};
    pairs.push_back({{"a", a}, {"b", b}});
  }
  return pairs;
}

TEST(GapCli, BatchEqualsSingleCalls) {
  const std::vector<json> pairs = fifty_pairs();
  const CliRun batch = run_distlab(json{{"pairs", pairs}}.dump());
  ASSERT_EQ(batch.code, 0) << batch.out << batch.err;
  const json results = batch.body()["results"];
  ASSERT_EQ(results.size(), pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const CliRun one = run_distlab(pairs[i].dump());
    ASSERT_EQ(one.code, 0) << i << one.err;
    const json s = one.body(), m = results[i];
    // Same fields; flags and counts exactly, numbers to the last bits.
    ASSERT_EQ(s.size(), m.size()) << i;
    EXPECT_EQ(s["overlap"], m["overlap"]) << i;
    EXPECT_EQ(s["converged"], m["converged"]) << i;
    EXPECT_EQ(s["iterations"], m["iterations"]) << i;
    EXPECT_EQ(s["validation"], m["validation"]) << i;
    const auto flat_s = s.flatten(), flat_m = m.flatten();
    for (const auto& [k, v] : flat_s.items()) {
      ASSERT_TRUE(flat_m.contains(k)) << i << k;
      if (v.is_number_float()) {
        EXPECT_NEAR(v.get<double>(), flat_m[k].get<double>(), 1e-12) << "pair " << i << " " << k;
      }
    }
  }
}

TEST(GapCli, EmptyBatch) {
  const CliRun r = run_distlab(R"({"pairs": []})");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.body(), json({{"results", json::array()}}));
}

TEST(GapCli, FixedPointAndNewtonAgree) {
  for (const json& pair : {example_pair(), json{{"a", box(0.3, 0.3, 0.3)},
                                                {"b", box(0.2, 0.4, 0.3, {0.6, 0.2, 0.1})}}}) {
    json newton = pair, plain = pair;
    newton["params"]["solver"] = "newton";
    plain["params"]["solver"] = "fixed_point";
    plain["params"]["tol"] = 1e-13;
    const CliRun rn = run_distlab(newton.dump()), rp = run_distlab(plain.dump());
    ASSERT_EQ(rn.code, 0) << rn.err;
    ASSERT_EQ(rp.code, 0) << rp.err;
    const json n = rn.body(), p = rp.body();
    EXPECT_TRUE(p["converged"].get<bool>());
    EXPECT_NEAR(n["distance"].get<double>(), p["distance"].get<double>(), 1e-8);
    EXPECT_GT(p["iterations"].get<int>(), n["iterations"].get<int>());
  }
}

// ---- refused input: field, exit code, and never a crash ------------------------------------

json with(json req, const json::json_pointer& at, json value) {
  req[at] = std::move(value);
  return req;
}

TEST(GapCli, BadInputNamesTheField) {
  const json base = {{"a", box(1, 1, 1)}, {"b", box(1, 1, 1, {3, 0, 0})}};
  const json cube_rows = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  struct Case {
    std::string name, request, field;
  };
  const std::vector<Case> cases = {
      {"unknown type", with(base, "/a/type"_json_pointer, "cone").dump(), "a.type"},
      {"type not a string", with(base, "/a/type"_json_pointer, 3).dump(), "a.type"},
      {"overflowing number",
       R"({"a": {"type": "box", "size": [1, 1, 1], "pose": {"position": [1e999, 0, 0]}},
           "b": {"type": "box", "size": [1, 1, 1]}})",
       "a.pose.position[0]"},
      {"huge coordinate", with(base, "/b/pose/position/1"_json_pointer, 1e300).dump(),
       "b.pose.position[1]"},
      {"position not a number", with(base, "/b/pose/position/2"_json_pointer, "x").dump(),
       "b.pose.position[2]"},
      {"empty polytope",
       with(base, "/a"_json_pointer,
            {{"type", "polytope"}, {"A", cube_rows}, {"b", {-1, -1, 1, 1, 1, 1}}})
           .dump(),
       "a"},
      {"polytope without rows",
       with(base, "/a"_json_pointer,
            {{"type", "polytope"}, {"A", json::array()}, {"b", json::array()}})
           .dump(),
       "a.A"},
      {"unbounded polytope",
       with(base, "/a"_json_pointer,
            {{"type", "polytope"}, {"A", {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}, {"b", {1, 1, 1}}})
           .dump(),
       "a"},
      {"polytope row of 2",
       with(base, "/a"_json_pointer, {{"type", "polytope"}, {"A", {{1, 0}}}, {"b", {1}}}).dump(),
       "a.A[0]"},
      {"flat hull",
       with(base, "/b"_json_pointer,
            {{"type", "convex_hull"}, {"points", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}}}})
           .dump(),
       "b.points"},
      {"non-positive size", with(base, "/b/size/2"_json_pointer, 0).dump(), "b.size[2]"},
      {"negative size", with(base, "/a/size/1"_json_pointer, -1).dump(), "a.size[1]"},
      {"size of 2", with(base, "/a/size"_json_pointer, {1, 1}).dump(), "a.size"},
      {"negative radius",
       with(base, "/b"_json_pointer, {{"type", "sphere"}, {"radius", -0.5}}).dump(), "b.radius"},
      {"cylinder without height",
       with(base, "/b"_json_pointer, {{"type", "cylinder"}, {"radius", 0.5}}).dump(), "b.height"},
      {"h = 0", with(base, "/params"_json_pointer, {{"h", 0}}).dump(), "params.h"},
      {"h negative", with(base, "/params"_json_pointer, {{"h", -0.1}}).dump(), "params.h"},
      {"k = 1.5", with(base, "/params"_json_pointer, {{"k", 1.5}}).dump(), "params.k"},
      {"k = 1", with(base, "/params"_json_pointer, {{"k", 1}}).dump(), "params.k"},
      {"k a string", with(base, "/params"_json_pointer, {{"k", "2"}}).dump(), "params.k"},
      {"eps = 0.5", with(base, "/params"_json_pointer, {{"eps", 0.5}}).dump(), "params.eps"},
      {"eps = 0", with(base, "/params"_json_pointer, {{"eps", 0}}).dump(), "params.eps"},
      {"sigma = 1", with(base, "/params"_json_pointer, {{"sigma", 1.0}}).dump(), "params.sigma"},
      {"sigma negative", with(base, "/params"_json_pointer, {{"sigma", -0.2}}).dump(),
       "params.sigma"},
      {"tol = 0", with(base, "/params"_json_pointer, {{"tol", 0}}).dump(), "params.tol"},
      {"max_iter negative", with(base, "/params"_json_pointer, {{"max_iter", -1}}).dump(),
       "params.max_iter"},
      {"unknown solver", with(base, "/params"_json_pointer, {{"solver", "magic"}}).dump(),
       "params.solver"},
      {"gradient not bool", with(base, "/params"_json_pointer, {{"gradient", 1}}).dump(),
       "params.gradient"},
      {"unknown param", with(base, "/params"_json_pointer, {{"alpha", 1}}).dump(), "params.alpha"},
      {"quaternion of 3", with(base, "/a/pose/quaternion"_json_pointer, {1, 0, 0}).dump(),
       "a.pose.quaternion"},
      {"zero quaternion", with(base, "/a/pose/quaternion"_json_pointer, {0, 0, 0, 0}).dump(),
       "a.pose.quaternion"},
      {"quaternion with a string",
       with(base, "/a/pose/quaternion"_json_pointer, {1, 0, 0, "z"}).dump(),
       "a.pose.quaternion[3]"},
      {"unknown pose key", with(base, "/a/pose/euler"_json_pointer, {0, 0, 0}).dump(),
       "a.pose.euler"},
      {"missing b", json{{"a", box(1, 1, 1)}}.dump(), "b"},
      {"unknown top-level key", with(base, "/extra"_json_pointer, 1).dump(), "extra"},
      {"unknown shape key", with(base, "/a/colour"_json_pointer, "red").dump(), "a.colour"},
      {"weights on a sphere",
       with(base, "/b"_json_pointer, {{"type", "sphere"}, {"radius", 1}, {"weights", {0.5}}})
           .dump(),
       "b.weights"},
      {"wrong number of weights", with(base, "/a/weights"_json_pointer, {0.1, 0.1}).dump(),
       "a.weights"},
      {"negative weight",
       with(base, "/a/weights"_json_pointer, {0.1, 0.1, -0.1, 0.1, 0.1, 0.1}).dump(),
       "a.weights[2]"},
      {"rho ball too small",
       with(base, "/a/rho"_json_pointer, {{"center", {0, 0, 0}}, {"radius", 0.5}}).dump(),
       "a.rho.radius"},
      {"Property 2 fails (weights 5 on a box)",
       with(base, "/a/weights"_json_pointer, {5.0, 5.0, 5.0, 5.0, 5.0, 5.0}).dump(), "a"},
      {"not an object", "[1, 2, 3]", ""},
      {"both a pair and pairs", with(base, "/pairs"_json_pointer, json::array()).dump(), "a"},
      {"bad shape in a batch",
       json{{"pairs",
             {{{"a", box(1, 1, 1)}, {"b", box(1, 1, 1, {3, 0, 0})}},
              {{"a", box(1, 1, 1)}, {"b", box(1, 1, 1, {3, 0, 0})}},
              {{"a", box(1, 1, 1)}, {"b", {{"type", "box"}, {"size", {1, -2, 1}}}}}}}}
           .dump(),
       "pairs[2].b.size[1]"},
      {"duplicate key", R"({"a": {"type": "sphere", "radius": 1, "radius": 2}, "b": {}})",
       "a.radius"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    expect_error(run_distlab(c.request), 2, "invalid_input", c.field);
  }
}

TEST(GapCli, MalformedJsonExits65WithBytePosition) {
  const CliRun r = run_distlab(R"({"a": {"type": "box", "size": [1, 1, 1]}, "b": )");
  expect_error(r, 65, "parse_error", "");
  EXPECT_GT(r.body()["error"]["byte"].get<int>(), 40);
  expect_error(run_distlab(""), 65, "parse_error", "");
  expect_error(run_distlab("{\"a\": NaN}"), 65, "parse_error", "");
  expect_error(run_distlab("{} trailing"), 65, "parse_error", "");
}

TEST(GapCli, HostileNestingIsACleanError) {
  for (const char* open_close : {"[]", "{}"}) {
    std::string deep;
    const int depth = 100000;
    if (open_close[0] == '[') {
      deep = std::string(depth, '[') + std::string(depth, ']');
    } else {
      for (int i = 0; i < depth; ++i) deep += "{\"a\":";
      deep += "1" + std::string(depth, '}');
    }
    const CliRun r = run_distlab(deep);
    expect_error(r, 2, "invalid_input", "");
    EXPECT_NE(r.body()["error"]["message"].get<std::string>().find("nested"), std::string::npos);
  }
}

TEST(GapCli, SizeLimits) {
  // More pairs than allowed: refused before any shape is built.
  json pairs = json::array();
  const json one = {{"a", {{"type", "sphere"}, {"radius", 1}}},
                    {"b", {{"type", "sphere"}, {"radius", 1}}}};
  for (std::size_t i = 0; i <= distlab::server::Limits{}.max_gap_pairs; ++i) pairs.push_back(one);
  expect_error(run_distlab(json{{"pairs", pairs}}.dump()), 2, "invalid_input", "pairs");
  // More polytope rows than allowed.
  json rows = json::array(), offsets = json::array();
  for (std::size_t i = 0; i <= distlab::server::Limits{}.max_polytope_rows; ++i) {
    const double t = 0.1 * static_cast<double>(i);
    rows.push_back({std::cos(t), std::sin(t), 0.3});
    offsets.push_back(1.0);
  }
  const json poly = {{"a", {{"type", "polytope"}, {"A", rows}, {"b", offsets}}},
                     {"b", box(1, 1, 1)}};
  expect_error(run_distlab(poly.dump()), 2, "invalid_input", "a.A");
  // A request over max_body_bytes.
  const CliRun big = run_distlab(std::string(distlab::server::Limits{}.max_body_bytes + 1, ' ') + "{}");
  expect_error(big, 2, "invalid_input", "");
  EXPECT_NE(big.body()["error"]["message"].get<std::string>().find("request too large"),
            std::string::npos);
}

TEST(GapCli, HelpAndUsage) {
  const CliRun help = run_distlab("", {"--help"});
  EXPECT_EQ(help.code, 0);
  EXPECT_NE(help.out.find("quaternion"), std::string::npos);
  EXPECT_NE(help.out.find("exit"), std::string::npos);
  const CliRun bad = run_distlab("{}", {"--frobnicate"});
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--frobnicate"), std::string::npos);
}

TEST(GapCli, ExampleAssetRuns) {
  const CliRun r = run_distlab(slurp(DISTLAB_SOURCE_DIR "/assets/gap/example.json"));
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const json b = r.body();
  EXPECT_FALSE(b["overlap"].get<bool>());
  EXPECT_GT(b["distance"].get<double>(), 0);
  expect_finite_numbers(b);
}

}  // namespace
