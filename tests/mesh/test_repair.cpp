// Repair and wrapping of user meshes, and the nearest-face transfer rule (mesh/repair.hpp).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Surface_mesh.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>

#include "distlab/geometry/error.hpp"
#include "distlab/geometry/progress.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/repair.hpp"
#include "mesh/cgal_mesh.hpp"

using namespace distlab;
using namespace distlab::mesh;

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<K::Point_3>;

long long step(const RepairResult& r, const std::string& name) {
  for (const auto& [n, c] : r.steps)
    if (n == name) return c;
  ADD_FAILURE() << "no step " << name;
  return -1;
}

// The unit sphere (icosphere level 3) without the faces whose centroid has z > 0.8: one hole.
SurfaceMesh sphere_with_hole() {
  const SurfaceMesh s = icosphere(1.0, 3);
  std::vector<Eigen::Index> keep;
  for (Eigen::Index f = 0; f < s.faces.rows(); ++f)
    if ((s.vertices(s.faces(f, 0), 2) + s.vertices(s.faces(f, 1), 2) + s.vertices(s.faces(f, 2), 2)) / 3 <= 0.8) keep.push_back(f);
  SurfaceMesh out{s.vertices, FacesX3(static_cast<Eigen::Index>(keep.size()), 3)};
  for (std::size_t i = 0; i < keep.size(); ++i) out.faces.row(static_cast<Eigen::Index>(i)) = s.faces.row(keep[i]);
  return out;
}

}  // namespace

// A unit box as an STL gives it (three vertices per face), one face listed twice, one face with
// a repeated vertex, one face missing (a 3-edge hole): each step counts what it changed, and the
// result is the closed box of volume 1 again.
TEST(Fix, EachStepCountsAndTheBoxIsClosedAgain) {
  const SurfaceMesh b = box(Vec3(1, 1, 1));
  SurfaceMesh soup;
  const Eigen::Index n = b.faces.rows() - 1;  // face 11 left out
  soup.vertices.resize(3 * n, 3);
  soup.faces.resize(n + 2, 3);
  for (Eigen::Index f = 0; f < n; ++f)
    for (int k = 0; k < 3; ++k) {
      soup.vertices.row(3 * f + k) = b.vertices.row(b.faces(f, k));
      soup.faces(f, k) = static_cast<int>(3 * f + k);
    }
  soup.faces.row(n) = soup.faces.row(0);  // duplicate of face 0
  soup.faces.row(n + 1) << 0, 0, 1;       // repeated vertex
  FixOptions options;
  options.max_hole_edges = 3;
  const RepairResult r = fix(soup, options);
  EXPECT_EQ(step(r, "merged_duplicate_vertices"), 3 * n - 8);  // the 8 corners remain
  EXPECT_EQ(step(r, "removed_duplicate_faces"), 1);
  EXPECT_EQ(step(r, "removed_degenerate_faces"), 1);
  EXPECT_EQ(step(r, "filled_holes"), 1);
  EXPECT_EQ(r.surface.faces.rows(), 12);
  EXPECT_EQ(topology_defect(r.surface), "");
  EXPECT_NEAR(signed_volume(r.surface), 1.0, 1e-12);
}

TEST(Fix, ALargeHoleIsRefusedWithTheRemainingDefect) {
  try {
    fix(sphere_with_hole(), FixOptions{4}, "repair");
    FAIL() << "a sphere with a large hole was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "repair");
    EXPECT_NE(std::string(e.what()).find("boundary edge"), std::string::npos) << e.what();
  }
}

TEST(Fix, FillingTheHoleClosesTheSphere) {
  const RepairResult r = fix(sphere_with_hole(), FixOptions{1000});
  EXPECT_EQ(step(r, "filled_holes"), 1);
  EXPECT_EQ(topology_defect(r.surface), "");
  EXPECT_GT(signed_volume(r.surface), 0);
}

using distlab::test::to_cgal;

// The wrap of the open sphere is closed and manifold; its one-sided distances (bounded error)
// agree with CGAL's approximate_Hausdorff_distance (random samples, 4000 per m²) within 10 %,
// and wrap → input is at least the offset (the wrap's vertices lie on the offset surface).
TEST(Wrap, AnOpenSphereIsWrappedAndItsDistancesAgreeWithCgal) {
  const SurfaceMesh open = sphere_with_hole();
  const RepairResult r = wrap(open, {0.2, 0.01}, {200000, 1e9, 1e9});
  EXPECT_EQ(topology_defect(r.surface), "");
  EXPECT_GT(signed_volume(r.surface), 0);
  const Mesh a = to_cgal(open), b = to_cgal(r.surface);
  namespace PMP = CGAL::Polygon_mesh_processing;
  const double in_to_wrap = PMP::approximate_Hausdorff_distance<CGAL::Sequential_tag>(a, b, PMP::parameters::number_of_points_per_area_unit(4000));
  const double wrap_to_in = PMP::approximate_Hausdorff_distance<CGAL::Sequential_tag>(b, a, PMP::parameters::number_of_points_per_area_unit(4000));
  std::printf("input→wrap %.4f (CGAL %.4f), wrap→input %.4f (CGAL %.4f)\n", r.input_to_result, in_to_wrap, r.result_to_input, wrap_to_in);
  EXPECT_NEAR(r.input_to_result, in_to_wrap, 0.1 * in_to_wrap);
  EXPECT_NEAR(r.result_to_input, wrap_to_in, 0.1 * wrap_to_in);
  EXPECT_GE(r.result_to_input, 0.009);
  EXPECT_THROW(wrap(open, {0.001, 0.0001}, {10000, 1e9, 1e9}), InvalidInput);  // too many faces for the limit
}

// A UV torus (major radius 1, minor 0.3), n × 2n quads split in two.
SurfaceMesh torus(int n) {
  SurfaceMesh m;
  m.vertices.resize(2 * n * n, 3);
  m.faces.resize(4 * n * n, 3);
  for (int i = 0; i < 2 * n; ++i)
    for (int j = 0; j < n; ++j) {
      const double u = M_PI * i / n, v = 2 * M_PI * j / n;
      m.vertices.row(i * n + j) << (1 + 0.3 * std::cos(v)) * std::cos(u), (1 + 0.3 * std::cos(v)) * std::sin(u), 0.3 * std::sin(v);
      const int a = i * n + j, b = ((i + 1) % (2 * n)) * n + j, c = ((i + 1) % (2 * n)) * n + (j + 1) % n, d = i * n + (j + 1) % n;
      m.faces.row(2 * (i * n + j)) << a, b, c;
      m.faces.row(2 * (i * n + j) + 1) << a, c, d;
    }
  return m;
}

// The estimate is within a factor of 2 of the wrap's face count on closed shapes at 5k+ faces
// (calibrated on these and the CAD part in issue 36's note), and the smallest α it suggests fits.
TEST(WrapEstimate, IsWithinAFactorOfTwoOfTheFacesMade) {
  struct Case {
    const char* name;
    SurfaceMesh mesh;
    double alpha;
  };
  const Case cases[] = {{"sphere", icosphere(1.0, 4), 0.05}, {"torus", torus(40), 0.03}, {"box", box(Vec3(1, 0.5, 0.3)), 0.025}};
  for (const Case& c : cases) {
    const WrapOptions o{c.alpha, c.alpha / 30};
    const WrapEstimate e = estimate_wrap(c.mesh, o);
    const RepairResult r = wrap(c.mesh, o, {1000000, 1e9, 1e9});
    const double ratio = e.faces / static_cast<double>(r.surface.faces.rows());
    std::printf("%s α %.3f: estimate %.0f faces, wrap %ld (ratio %.2f)\n", c.name, c.alpha, e.faces, static_cast<long>(r.surface.faces.rows()), ratio);
    EXPECT_GT(r.surface.faces.rows(), 5000) << c.name;
    EXPECT_GT(ratio, 0.5) << c.name;
    EXPECT_LT(ratio, 2.0) << c.name;
  }
}

// A tiny α is refused before any wrapping (no progress is reported), naming the α that fits,
// and that α's estimate is within the budget while a slightly smaller one is not.
TEST(WrapEstimate, ATinyAlphaIsRefusedUpFrontNamingTheAlphaThatFits) {
  const SurfaceMesh s = icosphere(1.0, 4);
  const WrapBudget budget{20000, 1e9, 1e9};
  int reports = 0;
  Progress progress;
  progress.report = [&](const std::string&, double f) { reports += f > 0; };
  try {
    wrap(s, {0.001, 0}, budget, "repair_options", progress);
    FAIL() << "a wrap of ~50M faces was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "repair_options.alpha");
    EXPECT_NE(std::string(e.what()).find("use alpha ≥"), std::string::npos) << e.what();
  }
  EXPECT_EQ(reports, 0);
  const double fit = smallest_alpha_within(s, {}, budget);
  EXPECT_LE(estimate_wrap(s, {fit, 0}).faces, 20000);
  EXPECT_GT(estimate_wrap(s, {fit * 0.99, 0}).faces, 20000);
  EXPECT_NO_THROW(require_wrap_within(s, {fit, 0}, budget));
}

// The transfer of a mesh onto its own vertices is the identity.
TEST(Transfer, OntoItsOwnVerticesIsTheIdentity) {
  const SurfaceMesh s = icosphere(0.5, 2);
  const Transfer t = nearest_face_transfer(s, s.vertices);
  std::vector<double> values;
  for (Eigen::Index v = 0; v < s.vertices.rows(); ++v) values.push_back(std::sin(3 * v));
  const std::vector<double> back = t.apply(values);
  for (std::size_t v = 0; v < values.size(); ++v) EXPECT_NEAR(back[v], values[v], 1e-9);
}

// σ = z on the sphere with a hole, carried to its wrap and back: barycentric interpolation is
// exact for a linear function, so each carried value is z at the closest point, and differs from
// z at the point itself by at most the distance to that closest point. Both directions reproduce
// the closed form within the measured distances (and within the offset plus the chord error).
TEST(Transfer, SigmaLinearInZRoundTripsThroughTheWrap) {
  const SurfaceMesh open = sphere_with_hole();
  const RepairResult r = wrap(open, {0.2, 0.01}, {200000, 1e9, 1e9});
  std::vector<double> z_user(static_cast<std::size_t>(open.vertices.rows()));
  for (std::size_t v = 0; v < z_user.size(); ++v) z_user[v] = open.vertices(static_cast<Eigen::Index>(v), 2);
  const Transfer forward = nearest_face_transfer(open, r.surface.vertices);
  const std::vector<double> on_wrap = forward.apply(z_user);
  for (std::size_t j = 0; j < on_wrap.size(); ++j)
    EXPECT_LE(std::abs(on_wrap[j] - r.surface.vertices(static_cast<Eigen::Index>(j), 2)), forward.distances[j] + 1e-12) << j;
  const Transfer back = nearest_face_transfer(r.surface, open.vertices);
  const std::vector<double> on_user = back.apply(on_wrap);
  std::vector<bool> used(on_user.size(), false);  // the cap's vertices are in no face
  for (Eigen::Index f = 0; f < open.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) used[static_cast<std::size_t>(open.faces(f, k))] = true;
  double worst = 0;
  for (std::size_t i = 0; i < on_user.size(); ++i)
    if (used[i]) worst = std::max(worst, std::abs(on_user[i] - z_user[i]));
  EXPECT_LE(worst, r.input_to_result + r.result_to_input);
  EXPECT_LT(worst, 0.1);
}

// Progress and cancellation (geometry/progress.hpp, the token of every job): reports of stage
// "repair" rise from 0 to 1, with some from inside CGAL's flood fill (strictly between 0 and 0.8).
TEST(Wrap, ReportsMonotoneProgressFromInsideTheFloodFill) {
  std::vector<double> seen;
  Progress progress;
  progress.report = [&](const std::string& stage, double f) {
    EXPECT_EQ(stage, "repair");
    seen.push_back(f);
  };
  wrap(sphere_with_hole(), {0.1, 0.01}, {200000, 1e9, 1e9}, "repair_options", progress);
  ASSERT_GE(seen.size(), 3u);
  EXPECT_EQ(seen.front(), 0.0);
  EXPECT_EQ(seen.back(), 1.0);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_GE(std::count_if(seen.begin(), seen.end(), [](double f) { return f > 0 && f < 0.8; }), 5);
}

// The token set from inside the flood fill (at its first report there) stops the wrap at its next
// gate: Cancelled, and no report after the one that cancelled.
TEST(Wrap, ACancelInsideTheFloodFillStopsItAtTheNextGate) {
  std::atomic<bool> cancel{false};
  int after = 0;
  double at = -1;
  Progress progress;
  progress.cancel = &cancel;
  progress.report = [&](const std::string&, double f) {
    if (cancel) ++after;
    if (f > 0 && !cancel) {
      at = f;
      cancel = true;
    }
  };
  EXPECT_THROW(wrap(sphere_with_hole(), {0.1, 0.01}, {200000, 1e9, 1e9}, "repair_options", progress), Cancelled);
  EXPECT_GT(at, 0);
  EXPECT_LT(at, 0.8);  // inside the flood fill, not after it
  EXPECT_EQ(after, 0);
}

// fix stops at its next step once cancelled.
TEST(Fix, ACancelStopsItAtTheNextStep) {
  std::atomic<bool> cancel{false};
  std::vector<double> seen;
  Progress progress;
  progress.cancel = &cancel;
  progress.report = [&](const std::string&, double f) {
    seen.push_back(f);
    if (f >= 0.4) cancel = true;
  };
  EXPECT_THROW(fix(sphere_with_hole(), FixOptions{1000}, "repair", progress), Cancelled);
  EXPECT_EQ(seen.back(), 0.4);
}

// A closed box with a fin (a triangle on one of its edges, which three faces then share): fix
// stitches and fills what it can and is still refused, so the advice for it is "wrap" alone; an
// open box needs fix's max_hole_edges (or wrap); a face turned over, fix (or wrap).
TEST(Fix, AFinIsLeftAndTheAdviceIsWrap) {
  SurfaceMesh m = box(Vec3(1, 1, 1));
  m.vertices.conservativeResize(9, 3);
  m.vertices.row(8) << 0, 2, 0.5;
  m.faces.conservativeResize(m.faces.rows() + 1, 3);
  m.faces.row(m.faces.rows() - 1) << 4, 5, 8;
  EXPECT_THROW(fix(m, FixOptions{1000}, "repair"), InvalidInput);
  EXPECT_NE(repair_advice(m).find("\"wrap\" can make it one (\"fix\" cannot"), std::string::npos) << repair_advice(m);

  SurfaceMesh open = box(Vec3(1, 1, 1));
  open.faces.conservativeResize(open.faces.rows() - 1, 3);
  EXPECT_NE(repair_advice(open).find("max_hole_edges"), std::string::npos) << repair_advice(open);
  EXPECT_NO_THROW(fix(open, FixOptions{3}, "repair"));

  SurfaceMesh flipped = box(Vec3(1, 1, 1));
  flipped.faces.row(0) = flipped.faces.row(0).reverse().eval();
  ASSERT_NE(topology_defect(flipped), "");
  EXPECT_EQ(repair_advice(flipped), "\"repair\": \"fix\" or \"wrap\" can make it one");
  EXPECT_NO_THROW(fix(flipped, FixOptions{}, "repair"));
}
