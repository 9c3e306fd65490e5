// A preparation's overall fraction (kelvin::StageProgress, issue 38 goal 3): its stages weighed by
// their shares, monotone through the reports a preparation makes (a cache miss and a hit), and the
// seconds of each stage timed from the reports.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/stages.hpp"
#include "sphere_fixture.hpp"

namespace distlab::kelvin {
namespace {

// Σ shares before stage i over Σ shares.
double before(const StageSeconds& shares, std::size_t i) {
  double sum = 0, total = 0;
  for (std::size_t j = 0; j < kPrepareStageCount; ++j) (j < i ? sum : total) += shares[j];
  return sum / (sum + total);
}

TEST(StageProgress, EachStageBeginsAtTheSharesOfTheStagesBeforeIt) {
  const StageSeconds shares = {0.1, 6, 0.3, 1.2, 0.4, 2};
  StageProgress p(shares);
  // A cache miss's reports in the order prepare_cached makes them.
  const std::vector<std::pair<std::string, double>> reports = {
      {"load", 0}, {"load", 0.5}, {"load", 1}, {"cache", 0}, {"invert", 0}, {"invert", 1}, {"mesh", 0.1}, {"mesh", 0.9}, {"mesh", 1}, {"build", 0}, {"build", 0.4}, {"build", 1}, {"decomp", 0}, {"decomp", 1}, {"cache", 0.5}, {"cache", 0.75}, {"cache", 1}, {"response", 0}, {"response", 0.5}, {"response", 1}};
  double last = 0;
  for (const auto& [stage, f] : reports) {
    const double overall = p.report(stage, f);
    EXPECT_GE(overall, last) << stage << " " << f;
    last = overall;
    if (f == 0 && stage != "cache" && stage != "invert") {
      EXPECT_NEAR(overall, before(shares, static_cast<std::size_t>(prepare_stage_index(stage, f))), 1e-12) << stage;
    }
  }
  EXPECT_NEAR(p.report("mesh", 0.5), 1.0, 1e-12) << "never below an earlier answer";
  // Inside a stage: its share times its fraction.
  StageProgress q(shares);
  q.report("load", 1);
  EXPECT_NEAR(q.report("mesh", 0.5), before(shares, 1) + 0.5 * (6 / 10.0), 1e-12);
  EXPECT_NEAR(q.report("cache", 0.75), before(shares, 4) + 0.5 * (0.4 / 10.0), 1e-12) << "the write runs over cache 0.5 … 1";
}

TEST(StageProgress, ALoadedFieldSkipsItsMeshingAndStaysMonotone) {
  StageProgress p({1, 5, 1, 1, 1, 1});
  double last = 0;
  for (const auto& [stage, f] : std::vector<std::pair<std::string, double>>{
           {"load", 1}, {"cache", 0}, {"build", 0.1}, {"build", 1}, {"wait", 0}, {"response", 0.5}, {"repair", 0.9}}) {
    const double overall = p.report(stage, f);
    EXPECT_GE(overall, last);
    last = overall;
  }
  EXPECT_NEAR(last, 0.9 + 0.5 / 10, 1e-12);  // all but half the response's share
}

TEST(StageProgress, ZeroOrBadSharesWeighTheStagesEqually) {
  StageProgress p({0, 0, 0, 0, 0, std::nan("")});
  EXPECT_NEAR(p.report("build", 0.5), 2.5 / 6, 1e-12);
}

// The seconds of each stage of a real preparation, timed from its reports: they add up to the
// preparation's time, and meshing is timed where Stats::t_mesh times it.
TEST(StageProgress, TimesAPreparationsStagesFromItsReports) {
  StageProgress stages(typical_stage_seconds(0, 1e4));
  Progress progress;
  double last = 0;
  bool monotone = true;
  progress.report = [&](const std::string& stage, double f) {
    const double overall = stages.report(stage, f);
    monotone = monotone && overall >= last;
    last = overall;
  };
  const testing::Sphere sphere;
  const auto t0 = std::chrono::steady_clock::now();
  const Field field = Field::prepare(testing::sphere_mesh(sphere), testing::sphere_options(0.15), progress);
  stages.finish();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_TRUE(monotone);
  const StageSeconds s = stages.seconds();
  double sum = 0;
  for (double x : s) sum += x;
  EXPECT_LE(sum, wall);
  EXPECT_GE(s[1], field.stats().t_mesh) << "mesh: from invert to build";
  EXPECT_GE(s[2], field.stats().t_build);
  EXPECT_GE(s[3], field.stats().t_decomp);
  EXPECT_EQ(s[4], 0) << "no store: no write";
}

TEST(StageProgress, TypicalSecondsGrowWithTheSizeAndTheGradedMeshingCostsMore) {
  const StageSeconds small = typical_stage_seconds(0, 1e4), large = typical_stage_seconds(0, 4e4), graded = typical_stage_seconds(0.05, 1e4);
  for (std::size_t i = 0; i < kPrepareStageCount; ++i) {
    EXPECT_GT(small[i], 0);
    EXPECT_NEAR(large[i] / small[i], std::pow(4.0, kStageSizeExponents[i]), 1e-9);
  }
  EXPECT_GT(graded[1], small[1]);
  // Meshing on two threads shortens the mesh stage by the parallel speed-up, and nothing else.
  const StageSeconds two = typical_stage_seconds(0, 1e4, 2);
  EXPECT_GT(mesh_speedup(2), 1.5);
  EXPECT_EQ(mesh_speedup(1), 1);
  for (std::size_t i = 0; i < kPrepareStageCount; ++i) EXPECT_DOUBLE_EQ(two[i], i == 1 ? small[i] / mesh_speedup(2) : small[i]) << i;
}

}  // namespace
}  // namespace distlab::kelvin
