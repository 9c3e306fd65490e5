// The Panda's records must not change when the robot becomes data (assets/robots/panda.urdf):
// every scenario file, both metrics and the GAP mode as_published, with every pair's distance
// and witnesses per step. Each record is encoded as `distlab cbf` writes it (JSON numbers
// round-trip, so equal text means equal doubles), the run-dependent "timing" left out, and its
// SHA-256 compared with tests/cbf/data/records.sha256, written by the code before the change
// (the Panda as C++ constants). Set DISTLAB_PRINT_RECORD_DIGESTS=1 to print the digests.
// The gap and published digests were retaken with Estrin's evaluation of Φ (more accurate Φ
// and Φ': tests/gap/test_base_function.cpp); the Euclidean ones are those of the Panda change.
// The gap and published digests were retaken again when GAP's gradient took a* − b* from
// ∇E_B(a*) (issue 19; `distlab cbf` before/after on the four scenarios: q moved by at most
// 4.3e-10 rad and D by 6.2e-11 in gap runs, q by 1.3e-14 in published runs, no infeasible step
// added or removed). Retaken when the rollout's pairs became tracked (gap_distance_tracked,
// issue 19; `distlab cbf` before/after on the four scenarios: q moved by at most 5.5e-12 rad and
// D by 1.4e-12 in gap runs; published runs: q and D unchanged, converged_distance by at most
// 5.4e-13; the same cold solves, no infeasible step added or removed). Retaken when Newton
// carried b − a apart from the points and scaled its stop rule near contact (issue 19: gap runs'
// q moved by at most 3.8e-15 rad, u by 2.2e-14 rad/s, D by 1.1e-15; published runs' q, u and D
// unchanged, only their converged reference D moved, by at most 4.6e-14, more than 1e-8 relative
// only where D < 6e-10; no infeasible step added or removed), and for the two together (tracked
// calls carry b − a too; `distlab cbf` against the second change alone: gap runs' q moved by at
// most 5.7e-12 rad, D by 1.4e-12; published runs' q, u and D unchanged, converged D by 5.3e-11
// relative at most; no infeasible step added or removed). The gap and published digests were
// retaken when spheres and cylinders were evaluated in world coordinates and E(β) took 1/β from a
// table (issue 38; `distlab cbf` before/after on the four scenarios: q moved by at most 3.7e-15
// rad, u by 2.0e-14 rad/s, D by 7.4e-16, converged D by 8.3e-16; euclidean runs unchanged; no
// infeasible step added or removed). Retaken when the saddle step solved by the adjugate without
// forming M⁻¹ (issue 38; `distlab cbf` before/after on the four scenarios: gap runs' q moved by at
// most 2.7e-15 rad, u by 2.4e-14 rad/s, D by 7.5e-16, witnesses by 9.1e-15; published runs' q, u
// and D unchanged, converged D by at most 3.3e-16; euclidean runs unchanged; no infeasible step
// added or removed).
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "distlab/kelvin/digest.hpp"
#include "distlab/server/cbf_json.hpp"

namespace distlab::cbf {
namespace {

// The record's keys as they were when the digests were taken (keys added later are not hashed).
const char* const kKeys[] = {"converged_distance", "distance", "dt", "gap_mode", "infeasible_steps",
                             "metric", "min_distance", "pairs", "q", "scenario", "slack",
                             "smoothness", "steps", "summary", "t", "task_error", "u",
                             "witness_a", "witness_b"};

std::string record_digest(const std::string& scenario, const std::string& run) {
  nlohmann::json request = {{"scenario", scenario},
                            {"metric", run == "euclidean" ? "euclidean" : "gap"},
                            {"params", {{"record_pairs", true}}}};
  if (run == "published")
    request["params"]["gap"] = {
        {"mode", "as_published"}, {"solver", "fixed_point"}, {"tol", 2e-4}, {"max_iter", 300}};
  const nlohmann::json record = server::run_cbf_request(request);
  nlohmann::json kept = nlohmann::json::object();
  for (const char* key : kKeys)
    if (record.contains(key)) kept[key] = record[key];
  const std::string text = kept.dump();
  kelvin::Sha256 h;
  h.add(text.data(), text.size());
  return h.hex();
}

std::map<std::string, std::string> pinned() {
  std::ifstream f(std::string(DISTLAB_SOURCE_DIR) + "/tests/cbf/data/records.sha256");
  std::map<std::string, std::string> out;
  std::string digest, name;
  while (f >> digest >> name) out[name] = digest;
  return out;
}

class RecordRegression : public ::testing::TestWithParam<const char*> {};

TEST_P(RecordRegression, EveryRunIsBitForBitUnchanged) {
  setenv("DISTLAB_ASSETS", DISTLAB_SOURCE_DIR "/assets", 1);
  const auto pins = pinned();
  const bool print = std::getenv("DISTLAB_PRINT_RECORD_DIGESTS") != nullptr;
  if (!print) {
    ASSERT_FALSE(pins.empty()) << "tests/cbf/data/records.sha256 missing";
  }
  for (const char* run : {"gap", "euclidean", "published"}) {
    const std::string name = std::string(GetParam()) + "." + run;
    const std::string d = record_digest(GetParam(), run);
    if (print) std::printf("%s %s\n", d.c_str(), name.c_str());
    if (print) continue;
    ASSERT_TRUE(pins.count(name)) << name;
    EXPECT_EQ(d, pins.at(name)) << name << ": the record changed";
  }
}

INSTANTIATE_TEST_SUITE_P(Scenarios, RecordRegression,
                         ::testing::Values("corridor", "corridor_real", "corridor_narrow",
                                           "corridor_fine_margin"));

}  // namespace
}  // namespace distlab::cbf
