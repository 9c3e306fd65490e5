// The boundary response (field.hpp, build_boundary_response): strokes applied by its columns
// against strokes solved with the factor and against full solves; its memory bound, progress
// and cancel.
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <thread>

#include "sphere_fixture.hpp"
#include "temp_dir.hpp"

using namespace distlab;
using namespace distlab::kelvin;
using namespace distlab::kelvin::testing;

namespace {

// 48 strokes of one stamp on 3–8% of the surface each (a cap of radius 0.35–0.55 R), "towards"
// or added, from a tilted σ.
std::vector<SigmaSpec> strokes(const Sphere& s, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<SigmaSpec> specs;
  SigmaSpec spec = tilted_sigma(s, 0.2);
  for (int edit = 0; edit < 48; ++edit) {
    const Vec3 at = s.centre + s.radius * Vec3(g(rng), g(rng), g(rng)).normalized();
    spec.brushes.push_back({at, s.radius * (0.35 + 0.2 * u(rng)), 2 * u(rng) - 1, s.radius * 0.05 * u(rng), edit >= 24});
    specs.push_back(spec);
  }
  return specs;
}

// V after each stroke, from a full solve of the tilted σ; background work on other threads.
std::vector<VecX> paint(Field& field, const Sphere& s, const std::vector<SigmaSpec>& specs, int* by_response) {
  field.set_sigma(tilted_sigma(s, 0.2), false, false);
  std::vector<VecX> values;
  std::vector<std::thread> workers;
  for (const SigmaSpec& spec : specs) {
    field.set_sigma(spec, false);
    EXPECT_GE(field.stats().linear_boundary, 0) << "every stroke by linearity";
    EXPECT_LE(field.stats().linear_boundary, static_cast<long>(field.boundary_points().size()) / 8);
    *by_response += field.stats().linear_by_response ? 1 : 0;
    values.push_back(field.vertex_values());
    if (auto work = field.background_work()) workers.emplace_back(std::move(work));
  }
  for (auto& w : workers) w.join();
  return values;
}

}  // namespace

// Strokes by the response's columns give V within 1e-13 of the same strokes solved with the
// factor and within 1e-12 of full solves, the same V bit for bit when painted again, and the
// boundary σ of a full solve bit for bit. A change of every boundary value reads more of the
// response than a solve reads of the factor: it is solved.
TEST(BoundaryResponse, StrokesByItsColumnsEqualSolvedStrokesAndFullSolves) {
  const Sphere s;
  Field field = Field::prepare(sphere_mesh(s), sphere_options(0.1));
  const auto specs = strokes(s, 23);
  int by_response = 0;
  const std::vector<VecX> solved = paint(field, s, specs, &by_response);
  EXPECT_EQ(by_response, 0);

  const double n_boundary = static_cast<double>(field.boundary_points().size());
  const double n_interior = static_cast<double>(field.stats().n_verts) - n_boundary;
  const double expected_mb = 8e-6 * n_interior * n_boundary;
  EXPECT_DOUBLE_EQ(field.boundary_response_megabytes(), expected_mb);
  const double size_before = field.stats().size_mb;
  ASSERT_TRUE(field.build_boundary_response(expected_mb * 1.001));
  EXPECT_DOUBLE_EQ(field.stats().response_mb, expected_mb);
  EXPECT_NEAR(field.stats().size_mb, size_before + expected_mb, 1e-9 * size_before);

  const std::vector<VecX> applied = paint(field, s, specs, &by_response);
  EXPECT_GE(by_response, 40) << "strokes on 5% of the surface read less of the response than a solve of the factor";
  int again_by_response = 0;
  const std::vector<VecX> again = paint(field, s, specs, &again_by_response);
  EXPECT_EQ(again_by_response, by_response);
  for (std::size_t k = 0; k < specs.size(); ++k) {
    EXPECT_LE(relative_difference(applied[k], solved[k]), 1e-13) << "stroke " << k;
    EXPECT_EQ(relative_difference(again[k], applied[k]), 0) << "stroke " << k << ": the same strokes, the same V";
  }
  for (std::size_t k = 0; k < specs.size(); k += 5) {
    field.set_sigma(specs[k], false, false);
    EXPECT_LE(relative_difference(applied[k], field.vertex_values()), 1e-12) << "stroke " << k;
  }

  // One stamp over the whole sphere changes every boundary value: solved with the factor.
  SigmaSpec all = specs.back();
  field.set_sigma(all, false);
  all.brushes.push_back({s.centre, 2 * s.radius, 0.5, 0, true});
  field.set_sigma(all, false);
  EXPECT_EQ(field.stats().linear_boundary, static_cast<long>(n_boundary));
  EXPECT_FALSE(field.stats().linear_by_response);
  const VecX whole = field.vertex_values();
  field.set_sigma(all, false, false);
  EXPECT_LE(relative_difference(whole, field.vertex_values()), 1e-12);

  field.release_boundary_response();
  EXPECT_EQ(field.stats().response_mb, 0);
  EXPECT_NEAR(field.stats().size_mb, size_before, 1e-9 * size_before);
}

// Beyond its memory bound the response is not built; a cancel leaves none; progress is stage
// "response" from 0 to 1.
TEST(BoundaryResponse, MemoryBoundCancelAndProgress) {
  const Sphere s;
  Field field = Field::prepare(sphere_mesh(s), sphere_options(0.1));
  const double mb = field.boundary_response_megabytes();
  EXPECT_FALSE(field.build_boundary_response(0.999 * mb));
  EXPECT_FALSE(field.build_boundary_response(std::nan("")));
  EXPECT_FALSE(field.build_boundary_response(-1));
  EXPECT_EQ(field.stats().response_mb, 0);

  std::atomic<bool> cancel{false};
  int reports = 0;
  Progress progress;
  progress.cancel = &cancel;
  progress.report = [&](const std::string& stage, double fraction) {
    EXPECT_EQ(stage, "response");
    if (++reports == 2) cancel = true;
    (void)fraction;
  };
  EXPECT_THROW(field.build_boundary_response(mb, progress), Cancelled);
  EXPECT_EQ(field.stats().response_mb, 0);

  cancel = false;
  std::vector<double> fractions;
  progress.report = [&](const std::string& stage, double fraction) {
    EXPECT_EQ(stage, "response");
    fractions.push_back(fraction);
  };
  ASSERT_TRUE(field.build_boundary_response(mb, progress));
  ASSERT_GE(fractions.size(), 3u);
  EXPECT_EQ(fractions.front(), 0);
  EXPECT_EQ(fractions.back(), 1);
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_DOUBLE_EQ(field.stats().response_mb, mb);
}

// A field loaded from the disk cache (factor read back, maxesize included) builds the same
// response: the same strokes give the same V bit for bit as on the field that was prepared.
TEST(BoundaryResponse, SameOnAFieldLoadedFromTheCache) {
  const Sphere s;
  const test::TempDir folder("distlab_response_cache");
  const std::string& dir = folder.path();
  bool hit = true;
  Field prepared = Field::prepare_cached(sphere_mesh(s), sphere_options(0.1), dir, {}, &hit);
  ASSERT_FALSE(hit);
  Field loaded = Field::prepare_cached(sphere_mesh(s), sphere_options(0.1), dir, {}, &hit);
  ASSERT_TRUE(hit);
  ASSERT_TRUE(prepared.build_boundary_response(1e3));
  ASSERT_TRUE(loaded.build_boundary_response(1e3));
  const auto specs = strokes(s, 31);
  int a = 0, b = 0;
  const std::vector<VecX> first = paint(prepared, s, specs, &a), second = paint(loaded, s, specs, &b);
  EXPECT_EQ(a, b);
  EXPECT_GE(a, 40);
  for (std::size_t k = 0; k < specs.size(); ++k) EXPECT_EQ(relative_difference(first[k], second[k]), 0) << "stroke " << k;
}
