// The sizing prepare chooses when PrepareOptions::grading is not given: predict_vertices against
// the counts Mesh_3 actually meshes, choose_grading on objects where eq. 23 or the graded sizing
// clearly wins, and the choice as Field reports and caches it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>

#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/surface_tools.hpp"
#include "distlab/kelvin/tet_mesh.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/surface.hpp"
#include "distlab/mesh/weld.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace distlab;
using namespace distlab::kelvin;

namespace {

mesh::SurfaceMesh asset(const std::string& name) {
  return mesh::weld(mesh::load_mesh(std::string(DISTLAB_ASSET_DIR) + "/" + name + ".stl")).surface;
}

// The surface inverted about its deepest point (or `about`) and the meshing parameters mesh_stage (field.cpp)
// gives it, far_radius 1.
struct Inverted {
  mesh::SurfaceMesh surface;
  MeshingParams params;
};
Inverted invert(const mesh::SurfaceMesh& s, double lx, double feature_angle, std::optional<Vec3> about = std::nullopt) {
  const Vec3 centre = about ? *about : SurfaceOracle(s).deepest_point();
  Inverted out{s, {}};
  double r_max = 0;
  for (Eigen::Index v = 0; v < s.vertices.rows(); ++v) {
    const Vec3 p = Vec3(s.vertices.row(v)) - centre;
    r_max = std::max(r_max, p.norm());
    out.surface.vertices.row(v) = p / p.squaredNorm();
  }
  out.params.lx = lx;
  out.params.min_size = lx / (r_max * r_max);
  out.params.feature_angle = feature_angle;
  return out;
}

double vertices_meshed(const Inverted& in, double grading) {
  MeshingParams p = in.params;
  p.grading = grading;
  return static_cast<double>(mesh_inverted_domain(in.surface, p, Progress{}).points.rows());
}

// The prediction is a model (Mesh_3's vertices per unit of ∫ dV / l³, fitted once on the cube):
// measured 1–10% off at 5k–400k vertices on the cube, the wrench and the knife for both sizings
// (notes of issue 19), so 12% is its claim. Cube with its sharp edges (the graded sizing's edge
// term), wrench without (feature_angle 180, as bench_kelvin meshes it).
TEST(PredictVertices, AgreesWithWhatMesh3Meshes) {
  struct Case {
    const char* name;
    mesh::SurfaceMesh surface;
    double lx, feature_angle;
  };
  const Case cases[] = {{"cube", mesh::box(Vec3::Ones()), 0.07, 60}, {"wrench", asset("wrench"), 0.003, 180}};
  for (const Case& c : cases) {
    Inverted in = invert(c.surface, c.lx, c.feature_angle);
    in.params.grading = kAutoGrading;
    const SizingPrediction p = predict_vertices(in.surface, in.params);
    const double paper = vertices_meshed(in, 0), graded = vertices_meshed(in, kAutoGrading);
    EXPECT_NEAR(p.paper / paper, 1.0, 0.12) << c.name << ": eq. 23 predicted " << p.paper << ", meshed " << paper;
    EXPECT_NEAR(p.graded / graded, 1.0, 0.12) << c.name << ": graded predicted " << p.graded << ", meshed " << graded;
  }
}

// The graded sizing refines near sharp edges (its edge term) and has Mesh_3 protect none, so the
// wrench with its edges, inverted about the case files' centre (0, 0, 0, inside the 5 mm plate),
// meshes as predicted at neighbouring l_x. When the graded sizing also protected the features
// Mesh_3 detects in y, the sphere patches near the centre faked 174 feature curves at l_x 0.0025
// against 28 at 0.0026, and the count jumped from 28.6k to 55.0k vertices.
TEST(PredictVertices, GradedSizingWithSharpEdgesFollowsLx) {
  const mesh::SurfaceMesh wrench = asset("wrench");
  for (const double lx : {0.0026, 0.0025}) {
    Inverted in = invert(wrench, lx, 60, Vec3::Zero());
    in.params.grading = kAutoGrading;
    const double predicted = predict_vertices(in.surface, in.params).graded, meshed = vertices_meshed(in, kAutoGrading);
    EXPECT_NEAR(predicted / meshed, 1.0, 0.12) << "l_x " << lx << ": predicted " << predicted << ", meshed " << meshed;
  }
}

// The vertices on the surface (the boundary values) are at least the prediction's lower bound,
// and so is the boundary response's memory, which the server uses to say a response will not be
// built: both sizings, with and without sharp edges, flat, curved and thin objects. Measured
// vertices per unit of ∫ dA / l²: 0.80 (sphere) to 5.2 (the cube graded at l_x 0.1).
TEST(PredictVertices, BoundaryVerticesBoundTheResponse) {
  struct Case {
    const char* name;
    mesh::SurfaceMesh surface;
    double lx, feature_angle, grading;
  };
  const mesh::SurfaceMesh cube = mesh::box(Vec3::Ones()), wrench = asset("wrench"), sphere = asset("sphere"), knife = asset("knife");
  const Case cases[] = {{"cube", cube, 0.07, 60, 0}, {"cube", cube, 0.05, 60, kAutoGrading}, {"cube", cube, 0.1, 60, kAutoGrading}, {"wrench", wrench, 0.005, 180, 0}, {"wrench", wrench, 0.004, 180, kAutoGrading}, {"sphere", sphere, 0.08, 60, 0}, {"knife", knife, 0.02, 180, kAutoGrading}};
  for (const Case& c : cases) {
    PrepareOptions o;
    o.lx = c.lx;
    o.feature_angle = c.feature_angle;
    o.grading = c.grading;
    const PreparePrediction p = predict_preparation(c.surface, o);
    const Field f = Field::prepare(c.surface, o);
    const auto boundary = static_cast<double>(f.boundary_points().size());
    std::printf("%s l_x %g grading %g: %ld vertices (%.0f predicted), %.0f on the surface (at least %.0f), response %.1f MB (at least %.1f)\n", c.name, c.lx,
                c.grading, f.stats().n_verts, p.vertices, boundary, p.boundary_vertices_min, f.boundary_response_megabytes(), p.response_megabytes_min());
    EXPECT_GT(p.boundary_vertices_min, 0.05 * boundary) << c.name << " " << c.lx;  // a bound that says something
    EXPECT_LE(p.boundary_vertices_min, boundary) << c.name << " " << c.lx;
    EXPECT_LE(p.response_megabytes_min(), f.boundary_response_megabytes()) << c.name << " " << c.lx;
  }
}

// Where the measured counts (notes of issue 19) leave no doubt: the graded sizing at fine l_x on
// the cube (185k against 394k at 0.02) and on thin objects (the knife at 0.01: 23k against 138k;
// the wrench at 0.002: 30k against 84k), eq. 23 where the cube's edge refinement costs more than
// grading saves (0.05: 35.7k against 26.2k) or where the saving is too small to pay for graded
// meshing (0.03: 94k against 118k), and on the sphere, where grading changes nothing (the whole
// mesh is at the size bound).
TEST(ChooseGrading, TakesTheGradedSizingOnlyWhereItSavesClearly) {
  const mesh::SurfaceMesh cube = mesh::box(Vec3::Ones()), knife = asset("knife"), wrench = asset("wrench"), sphere = asset("sphere");
  EXPECT_EQ(choose_grading(invert(cube, 0.02, 60).surface, invert(cube, 0.02, 60).params), kAutoGrading);
  EXPECT_EQ(choose_grading(invert(knife, 0.01, 180).surface, invert(knife, 0.01, 180).params), kAutoGrading);
  EXPECT_EQ(choose_grading(invert(knife, 0.02, 180).surface, invert(knife, 0.02, 180).params), kAutoGrading);  // 6.7k against 17k
  EXPECT_EQ(choose_grading(invert(wrench, 0.002, 180).surface, invert(wrench, 0.002, 180).params), kAutoGrading);
  EXPECT_EQ(choose_grading(invert(cube, 0.05, 60).surface, invert(cube, 0.05, 60).params), 0.0);
  EXPECT_EQ(choose_grading(invert(cube, 0.03, 60).surface, invert(cube, 0.03, 60).params), 0.0);
  EXPECT_EQ(choose_grading(invert(sphere, 0.02, 60).surface, invert(sphere, 0.02, 60).params), 0.0);
  EXPECT_EQ(choose_grading(invert(cube, 0.15, 60).surface, invert(cube, 0.15, 60).params), 0.0);  // below kAutoPredictFrom
}

// Not given, the grading is chosen, reported in Stats, and the field is the one an explicit
// request for that sizing gives; a cache hit reports the same choice.
TEST(ChooseGrading, FieldReportsAndCachesTheChoice) {
  const test::TempDir folder("distlab_sizing_choice");
  const fs::path dir = folder.path();
  const mesh::SurfaceMesh wrench = asset("wrench");
  PrepareOptions chosen;
  chosen.lx = 0.003;
  chosen.feature_angle = 180;
  PrepareOptions explicit_graded = chosen;
  explicit_graded.grading = kAutoGrading;
  bool hit = true;
  const Field a = Field::prepare_cached(wrench, chosen, dir.string(), {}, &hit);
  EXPECT_FALSE(hit);
  EXPECT_EQ(a.stats().grading, kAutoGrading);
  const Field b = Field::prepare_cached(wrench, explicit_graded, dir.string(), {}, &hit);
  EXPECT_FALSE(hit);  // another request, another entry
  EXPECT_EQ(a.stats().n_verts, b.stats().n_verts);
  EXPECT_EQ(a.stats().n_tets, b.stats().n_tets);
  const Field c = Field::prepare_cached(wrench, chosen, dir.string(), {}, &hit);
  EXPECT_TRUE(hit);
  EXPECT_EQ(c.stats().grading, kAutoGrading);
  EXPECT_EQ(c.stats().n_verts, a.stats().n_verts);
  // Where the choice is the graded sizing, an explicit 0 is still eq. 23 (25k vertices against
  // 13k), and its own cache entry.
  PrepareOptions explicit_paper = chosen;
  explicit_paper.grading = 0.0;
  const Field p = Field::prepare_cached(wrench, explicit_paper, dir.string(), {}, &hit);
  EXPECT_FALSE(hit);
  EXPECT_EQ(p.stats().grading, 0.0);
  EXPECT_GT(p.stats().n_verts, a.stats().n_verts * 3 / 2);

  PrepareOptions coarse;  // the cube below kAutoPredictFrom: eq. 23, as with grading 0
  coarse.lx = 0.15;
  PrepareOptions paper = coarse;
  paper.grading = 0.0;
  const Field d = Field::prepare(mesh::box(Vec3::Ones()), coarse), e = Field::prepare(mesh::box(Vec3::Ones()), paper);
  EXPECT_EQ(d.stats().grading, 0.0);
  EXPECT_EQ(d.stats().n_verts, e.stats().n_verts);
}

// With sharp edges (feature_angle 60) the choice is made the same way and the graded meshing
// (refined near the edges, none protected) converges: the knife at l_x 0.02 (22.1k vertices by
// eq. 23 with its edges protected, 10.9k graded) gets the graded sizing, no warning, a field that
// solves; progress reports the prediction as the first tenth of "mesh", never going back.
TEST(ChooseGrading, WithSharpEdges) {
  PrepareOptions options;
  options.lx = 0.02;
  options.feature_angle = 60;
  std::vector<double> mesh_fractions;
  Progress progress;
  progress.report = [&](const std::string& stage, double fraction) {
    if (stage == "mesh") mesh_fractions.push_back(fraction);
  };
  Field field = Field::prepare(asset("knife"), options, progress);
  EXPECT_EQ(field.stats().grading, kAutoGrading);
  EXPECT_TRUE(field.stats().warnings.empty());
  EXPECT_LT(field.stats().n_verts, 18000);
  ASSERT_GE(mesh_fractions.size(), 3u);
  EXPECT_EQ(mesh_fractions.front(), 0);
  EXPECT_LT(mesh_fractions[1], 0.1);
  EXPECT_TRUE(std::is_sorted(mesh_fractions.begin(), mesh_fractions.end()));
  SigmaSpec sigma;
  sigma.constant = 0.2;
  field.set_sigma(sigma);
  const Sample far = field.query(Vec3(3, 1, 2));
  EXPECT_EQ(far.status, Status::ok);
  EXPECT_TRUE(std::isfinite(far.h) && far.h > 0.2);
}

}  // namespace
