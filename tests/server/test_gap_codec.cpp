// The GAP request codec (run_gap_request, shared by the CLI, the server and the Python bindings):
// overlapping pairs get their Euclidean penetration, and the caller's checkpoint (the server's
// request deadline) is met before each one, not only once per chunk of 64 pairs.
#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>

#include "distlab/server/gap_json.hpp"

namespace distlab::server {
namespace {

using nlohmann::json;

// Concentric spheres: every direction is as deep as any other, the hardest case for EPA (it took
// 4 s of CPU per pair before its tolerance on round shapes was made coarse). Closed form: depth
// r_a + r_b along any unit n, witness_a = r_a n, witness_b = -r_b n.
json concentric_pairs(int n) {
  json pairs = json::array();
  for (int i = 0; i < n; ++i)
    pairs.push_back({{"a", {{"type", "sphere"}, {"radius", 0.3}}}, {"b", {{"type", "sphere"}, {"radius", 0.2}}}});
  return {{"pairs", pairs}, {"params", {{"validate", false}}}};
}

TEST(GapCodec, ConcentricSpheresPenetrateByTheSumOfTheRadii) {
  const json out = run_gap_request(concentric_pairs(3));
  ASSERT_EQ(out["results"].size(), 3u);
  for (const json& r : out["results"]) {
    const json& p = r["euclidean"]["penetration"];
    EXPECT_NEAR(p["depth"].get<double>(), 0.5, 1e-9);
    const Vec3 n(p["direction"][0], p["direction"][1], p["direction"][2]);
    EXPECT_NEAR(n.norm(), 1, 1e-12);
    const Vec3 wa(p["witness_a"][0], p["witness_a"][1], p["witness_a"][2]);
    const Vec3 wb(p["witness_b"][0], p["witness_b"][1], p["witness_b"][2]);
    EXPECT_LT((wa - 0.3 * n).norm(), 1e-6);
    EXPECT_LT((wb + 0.2 * n).norm(), 1e-6);
  }
}

TEST(GapCodec, TheCheckpointRunsBeforeEveryPenetration) {
  std::atomic<int> calls{0};
  const json out = run_gap_request(
      concentric_pairs(6), [&] { ++calls; }, Limits{});
  ASSERT_EQ(out["results"].size(), 6u);
  // Once before the chunk, once before each of the 6 penetrations (more before: parsing).
  EXPECT_GE(calls.load(), 7);
  // And a checkpoint that throws stops the request midway, with its own error.
  std::atomic<int> left{3};
  EXPECT_THROW(run_gap_request(
                   concentric_pairs(6), [&] {
                     if (--left < 0) throw std::runtime_error("deadline");
                   },
                   Limits{}),
               std::runtime_error);
}

}  // namespace
}  // namespace distlab::server
