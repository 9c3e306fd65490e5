// Outcomes of the semantic CBF scenario wrench_grasp (assets/scenarios/wrench_grasp.json): the
// Panda's finger pads and the paper's wrench (kelvin-semantics-aware-distance.txt, case (a) of
// eq. 24) run three ways. Outcomes only, never times.
#include <cmath>
#include <fstream>
#include <functional>
#include <map>

#include <gtest/gtest.h>

#include "distlab/cbf/feasibility.hpp"
#include "distlab/geometry/error.hpp"
#include "distlab/server/cbf_json.hpp"
#include "temp_dir.hpp"

namespace distlab::cbf {
namespace {

using nlohmann::json;

const std::string kAssets = std::string(DISTLAB_SOURCE_DIR) + "/assets";

// The wrench is prepared once per process, through a disk cache of the test's own (removed at exit).
kelvin::Field prepare(const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options, const std::string&) {
  static const distlab::test::TempDir dir("distlab-wrench-grasp");
  return kelvin::Field::prepare_cached(surface, options, dir.path());
}

const RolloutRecord& run(const json& params) {
  static std::map<std::string, RolloutRecord> cache;
  const std::string key = params.dump();
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  const json request = {{"scenario", "wrench_grasp"}, {"metric", "euclidean"}, {"params", params}};
  const server::CbfRequest r = server::parse_cbf_request(request, kAssets, prepare);
  return cache.emplace(key, rollout(r.scenario, r.metric, r.options)).first->second;
}

// wrench_grasp as parsed (its field prepared through the test's cache).
const Scenario& run_scenario() {
  static const Scenario s =
      server::parse_cbf_request({{"scenario", "wrench_grasp"}, {"metric", "euclidean"}}, kAssets, prepare).scenario;
  return s;
}

const json kSemantic = json::object();
const json kAvoid = {{"fields", {{{"sigma", json::object()}}}}};
const json kHull = {{"field_mode", "hull"}};

double min_h(const RolloutRecord& rec) {
  double m = INFINITY;
  for (const StepRecord& s : rec.steps)
    for (const FieldPointSample& p : s.field_points) m = std::min(m, p.h);
  return m;
}

TEST(WrenchGrasp, SemanticSigmaLetsThePadsReachTheHandleAndKeepsThemFromTheEnds) {
  const RolloutRecord& rec = run(kSemantic);
  ASSERT_TRUE(rec.failure.empty()) << rec.failure;
  EXPECT_TRUE(rec.infeasible_steps.empty());
  EXPECT_TRUE(rec.reached) << rec.final_task_error;
  const double delta = rec.field_margins[0];
  EXPECT_GE(min_h(rec), delta);  // every control point, every step
  const FieldContact& end = rec.steps.back().field_contacts[0];
  EXPECT_LE(end.allowed_distance, 0.002);  // the pads at the handle
  EXPECT_GT(end.sigma, delta);             // where contact is allowed
  double forbidden = INFINITY;
  for (const StepRecord& s : rec.steps) forbidden = std::min(forbidden, s.field_contacts[0].forbidden_distance);
  EXPECT_GT(rec.safety_distances[0], 0.001);
  EXPECT_GE(forbidden, rec.safety_distances[0]);
  std::printf(
      "semantic: min h %.4f (delta %.2f), pads to handle %.4f m, sigma there %.3f, to the ends >= %.4f m "
      "(safety distance %.4f m)\n",
      min_h(rec), delta, end.allowed_distance, end.sigma, forbidden, rec.safety_distances[0]);
}

TEST(WrenchGrasp, ZeroSigmaKeepsThePadsAwayFromTheWholeSurface) {
  const RolloutRecord& rec = run(kAvoid);
  ASSERT_TRUE(rec.failure.empty()) << rec.failure;
  EXPECT_TRUE(rec.infeasible_steps.empty());
  const double delta = rec.field_margins[0];
  EXPECT_GE(min_h(rec), delta);
  const FieldContact& end = rec.steps.back().field_contacts[0];
  // σ = 0: h ≥ δ holds off the surface, so the pads stop clearly farther than the semantic run's.
  EXPECT_GT(end.distance, 0.003);
  EXPECT_EQ(end.sigma, 0);
  std::printf("sigma 0: min h %.4f, pads to the wrench %.4f m at the end, gripper opening %.4f m\n", min_h(rec),
              end.distance, 2 * rec.q_final[7]);
}

TEST(WrenchGrasp, TheConvexHullWithEuclideanDistancesStopsThePadsAboveTheHandle) {
  const RolloutRecord& rec = run(kHull);
  ASSERT_TRUE(rec.field_names.empty());  // the hull is an obstacle, not a field
  EXPECT_TRUE(rec.infeasible_steps.empty());
  EXPECT_FALSE(rec.reached);
  // Held at the Euclidean margin from the hull, which covers the handle's sides.
  double hull_clearance = INFINITY;
  for (std::size_t p = 0; p < rec.pairs.size(); ++p)
    if (rec.pairs[p].name.ends_with("/wrench")) hull_clearance = std::min(hull_clearance, rec.steps.back().pairs[p].clearance);
  EXPECT_NEAR(hull_clearance, 0.002, 2e-4);
  EXPECT_GT(rec.final_state.position_error, 0.003);
  std::printf("hull: clearance to the hull %.4f m, TCP %.4f m from the target\n", hull_clearance,
              rec.final_state.position_error);
}

TEST(WrenchGrasp, ReachingForAForbiddenEndTheBarrierOpensTheFingers) {
  // The target moved over the ring end (σ = −0.5 there): the task pulls the pads onto the end,
  // the field rows push them off; the QP opens the fingers (u of the finger joint) so that the
  // hand arrives with the pads beside the end, every point at h ≥ δ.
  std::ifstream in(kAssets + "/scenarios/wrench_grasp.json");
  json scenario = json::parse(in);
  scenario["target"]["position"][0] = 0.455;
  const server::CbfRequest r = server::parse_cbf_request({{"scenario", scenario}, {"metric", "euclidean"}}, kAssets, prepare);
  const RolloutRecord rec = rollout(r.scenario, r.metric, r.options);
  ASSERT_TRUE(rec.failure.empty()) << rec.failure;
  EXPECT_TRUE(rec.infeasible_steps.empty());
  EXPECT_GE(min_h(rec), rec.field_margins[0]);
  double forbidden = INFINITY;
  for (const StepRecord& s : rec.steps) forbidden = std::min(forbidden, s.field_contacts[0].forbidden_distance);
  EXPECT_GE(forbidden, rec.safety_distances[0]);
  EXPECT_GT(forbidden, 0.005);                          // far more than the handle's 1.5 mm
  EXPECT_GT(rec.q_final[7], r.scenario.q0[7] + 0.005);  // the fingers opened
  std::printf("over the ring end: min h %.4f, pads to the end >= %.4f m, finger opening %.4f -> %.4f m\n", min_h(rec), forbidden,
              2 * r.scenario.q0[7], 2 * rec.q_final[7]);
}

// Bad fields and control points are refused naming the field, before any run.
TEST(WrenchGrasp, ErrorsNameTheField) {
  json scenario;
  {
    std::ifstream in(kAssets + "/scenarios/wrench_grasp.json");
    scenario = json::parse(in);
  }
  const auto field_of = [&](const std::function<void(json&)>& edit, const json& params = json::object()) {
    json s = scenario;
    edit(s);
    try {
      server::parse_cbf_request({{"scenario", s}, {"metric", "euclidean"}, {"params", params}}, kAssets, prepare);
    } catch (const InvalidInput& e) {
      return e.field();
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(field_of([](json& s) { s["control_points"][0]["link"] = "panda_link99"; }), "scenario.control_points[0].link");
  EXPECT_EQ(field_of([](json& s) { s["control_points"][0]["point"] = {0, 0}; }), "scenario.control_points[0].point");
  EXPECT_EQ(field_of([](json& s) { s["control_points"][24]["sample"] = 0; }), "scenario.control_points[24].sample");
  EXPECT_EQ(field_of([](json& s) { s["control_points"][24]["element"] = "nope"; }), "scenario.control_points[24].element");
  EXPECT_EQ(field_of([](json& s) { s["fields"][0]["mesh"] = {{"asset", "no_such_mesh"}}; }), "scenario.fields[0].mesh.asset");
  EXPECT_EQ(field_of([](json& s) { s["fields"][0].erase("lx"); }), "scenario.fields[0].lx");
  EXPECT_EQ(field_of([](json& s) { s["fields"][0]["lx_fraction"] = 0.1; }), "scenario.fields[0].lx");  // both given
  EXPECT_EQ(field_of([](json& s) { s["fields"][0]["sigma"]["axis"]["width"] = -1; }).rfind("scenario.fields[0].sigma", 0), 0U);
  EXPECT_EQ(field_of([](json& s) { s["fields"][0]["colour"] = 1; }), "scenario.fields[0].colour");
  // The Kelvin objects' reshaping keys, read by the same codec (ReshapeRequest).
  EXPECT_EQ(field_of([](json& s) { s["fields"][0]["components"] = "some"; }), "scenario.fields[0].components");
  EXPECT_EQ(field_of([](json& s) { s["fields"][0]["simplify"] = {{"faces", 2}}; }), "scenario.fields[0].simplify.faces");
  EXPECT_EQ(field_of([](json& s) { s["fields"][0]["repair"] = "glue"; }), "scenario.fields[0].repair");
  EXPECT_EQ(field_of([](json& s) { s.erase("control_points"); }), "scenario.fields");
  EXPECT_EQ(field_of([](json&) {}, {{"fields", json::array()}}), "params.fields");
  EXPECT_EQ(field_of([](json&) {}, {{"fields", {{{"lx", 1}}}}}), "params.fields[0].lx");
  EXPECT_EQ(field_of([](json&) {}, {{"field_mode", "mesh"}}), "params.field_mode");
  // A σ given in params is named there, not in the scenario it replaced.
  EXPECT_EQ(field_of([](json&) {}, {{"fields", {{{"sigma", {{"per_vertex", {0.5, 0.5, 0.5}}}}}}}}),
            "params.fields[0].sigma.per_vertex");
  EXPECT_EQ(field_of([](json& s) { s["fields"][0]["sigma"]["per_vertex"] = {0.5, 0.5}; }),
            "scenario.fields[0].sigma.per_vertex");
  // A start inside the unsafe set (the hand lowered onto the ends: δ above what h is there).
  EXPECT_EQ(field_of([](json&) {}, {{"fields", {{{"delta", 5}}}}}), "(accepted)");  // parsing accepts it ...
  const server::CbfRequest r = server::parse_cbf_request(
      {{"scenario", "wrench_grasp"}, {"metric", "euclidean"}, {"params", {{"fields", {{{"delta", 5}}}}}}}, kAssets, prepare);
  EXPECT_THROW(rollout(r.scenario, r.metric, r.options), InvalidInput);  // ... the run's start check refuses it
  // ... and the feasibility check says so before any run.
  const json feasibility = server::encode_feasibility(target_feasibility(r.scenario), r.scenario);
  EXPECT_EQ(feasibility["start_safe"], false);
  EXPECT_NE(feasibility["start_problem"].get<std::string>().find("unsafe set of field \"wrench\""), std::string::npos)
      << feasibility.dump();
  EXPECT_EQ(server::encode_feasibility(target_feasibility(run_scenario()), run_scenario())["start_safe"], true);
}

}  // namespace
}  // namespace distlab::cbf
