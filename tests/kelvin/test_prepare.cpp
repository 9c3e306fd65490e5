// Preparation: refused inputs, progress and cancellation, and the cache round trip.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/surface.hpp"
#include "sphere_fixture.hpp"

namespace fs = std::filesystem;
using namespace distlab;
using namespace distlab::kelvin;
using namespace distlab::kelvin::testing;

namespace {

const Sphere kSphere;

std::string refused_field(const mesh::SurfaceMesh& m, const PrepareOptions& o) {
  try {
    Field::prepare(m, o);
  } catch (const InvalidInput& e) {
    return e.field() + ": " + e.what();
  }
  return "accepted";
}

fs::path fresh_dir(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("distlab_kelvin_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

}  // namespace

TEST(KelvinPrepare, RefusesBadInputNamingTheField) {
  mesh::SurfaceMesh open = mesh::icosphere(0.5, 2);
  open.faces.conservativeResize(open.faces.rows() - 1, 3);
  EXPECT_EQ(refused_field(open, sphere_options(0.2)).rfind("mesh: ", 0), 0u) << refused_field(open, sphere_options(0.2));
  EXPECT_NE(refused_field(open, sphere_options(0.2)).find("3 boundary edges"), std::string::npos);

  const mesh::SurfaceMesh ball = mesh::icosphere(0.5, 2);
  PrepareOptions o = sphere_options(0.2);
  o.centre = Vec3(2, 0, 0);
  EXPECT_EQ(refused_field(ball, o).rfind("center: center lies outside", 0), 0u) << refused_field(ball, o);
  o.centre = Vec3(0.495, 0, 0);
  EXPECT_EQ(refused_field(ball, o).rfind("center: center is too close", 0), 0u) << refused_field(ball, o);
  for (double lx : {0.0, -1.0, std::nan(""), 5.0}) {
    o = sphere_options(lx);
    EXPECT_EQ(refused_field(ball, o).rfind("lx: ", 0), 0u) << lx << " " << refused_field(ball, o);
  }
}

TEST(KelvinPrepare, SigmaAndLevelsAreValidated) {
  Field field = Field::prepare(sphere_mesh(kSphere), sphere_options(0.2));
  SigmaSpec s;
  s.per_vertex = VecX::Zero(5);
  try {
    field.set_sigma(s);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "sigma.per_vertex");
  }
  s.per_vertex = VecX::Constant(field.surface().vertices.rows(), 0.25);
  field.set_sigma(s);
  EXPECT_NEAR(field.boundary_sigma().minCoeff(), 0.25, 1e-12);
  EXPECT_NEAR(field.boundary_sigma().maxCoeff(), 0.25, 1e-12);
  EXPECT_THROW(field.isosurface(std::nan("")), InvalidInput);
}

TEST(KelvinPrepare, ReportsProgressAndCancels) {
  std::vector<std::string> stages;
  Progress progress;
  progress.report = [&](const std::string& stage, double) {
    if (stages.empty() || stages.back() != stage) stages.push_back(stage);
  };
  Field::prepare(sphere_mesh(kSphere), sphere_options(0.2), progress);
  EXPECT_EQ(stages, (std::vector<std::string>{"load", "invert", "mesh", "build", "decomp"}));

  // Cancellation requested while Mesh_3 runs is noticed inside its refinement loop.
  std::atomic<bool> cancel{false};
  progress.cancel = &cancel;
  progress.report = [&](const std::string& stage, double f) {
    if (stage == "mesh" && f > 0) cancel = true;
  };
  EXPECT_THROW(Field::prepare(sphere_mesh(kSphere), sphere_options(0.2), progress), Cancelled);
}

TEST(KelvinPrepare, CacheRoundTripAndCorruptionIsRebuilt) {
  const fs::path dir = fresh_dir("cache");
  const auto surface = sphere_mesh(kSphere);
  bool hit = true;
  Field a = Field::prepare_cached(surface, sphere_options(0.2), dir.string(), {}, &hit);
  EXPECT_FALSE(hit);
  Field b = Field::prepare_cached(surface, sphere_options(0.2), dir.string(), {}, &hit);
  EXPECT_TRUE(hit);
  // A cached object reports its original preparation times and says it was loaded.
  EXPECT_FALSE(a.stats().cached);
  EXPECT_TRUE(b.stats().cached);
  EXPECT_EQ(b.stats().t_mesh, a.stats().t_mesh);
  EXPECT_EQ(b.stats().t_decomp, a.stats().t_decomp);
  EXPECT_GT(b.stats().t_mesh, 0.0);
  EXPECT_GT(b.stats().t_load, 0.0);
  a.set_sigma(constant_sigma(0.2));
  b.set_sigma(constant_sigma(0.2));
  EXPECT_TRUE((a.tet_mesh().points.array() == b.tet_mesh().points.array()).all());
  for (const Vec3& x : shell_points(kSphere, 1.01, 5, 200)) EXPECT_EQ(a.query(x).h, b.query(x).h);

  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir)) files.push_back(entry.path());
  ASSERT_EQ(files.size(), 1u);  // no temporary file left behind
  const fs::path file = files[0];

  // Truncated, one flipped byte, trailing garbage: each is detected, rebuilt and rewritten.
  for (int damage = 0; damage < 3; ++damage) {
    const auto size = fs::file_size(file);
    if (damage == 0) fs::resize_file(file, size / 2);
    if (damage == 1) {
      std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
      f.seekg(static_cast<std::streamoff>(size / 3));
      const char c = static_cast<char>(f.get());
      f.seekp(static_cast<std::streamoff>(size / 3));
      f.put(static_cast<char>(c ^ 0x20));
    }
    if (damage == 2) std::ofstream(file, std::ios::app | std::ios::binary) << "trailing";
    Field c = Field::prepare_cached(surface, sphere_options(0.2), dir.string(), {}, &hit);
    EXPECT_FALSE(hit) << damage;
    c.set_sigma(constant_sigma(0.2));
    const Vec3 x(0.9, 0.1, 0.2);
    EXPECT_EQ(c.query(x).h, a.query(x).h);
    Field::prepare_cached(surface, sphere_options(0.2), dir.string(), {}, &hit);
    EXPECT_TRUE(hit) << damage;
  }

  // A different lx is a different entry.
  Field::prepare_cached(surface, sphere_options(0.25), dir.string(), {}, &hit);
  EXPECT_FALSE(hit);
  fs::remove_all(dir);
}

// The wrench asset (a 5 mm plate with a ring end and an open end, 96.47 mm long) meshes without
// edge protection (see PrepareOptions::feature_angle), centre of inversion at its centre as in
// the paper, and h = σ holds on its surface for the σ of case (c) (eq. 24).
TEST(KelvinPrepare, WrenchMeshesAndMatchesSigma) {
  const mesh::SurfaceMesh wrench = mesh::load_mesh(std::string(DISTLAB_ASSET_DIR) + "/wrench.stl");
  PrepareOptions o;
  o.lx = 0.006;
  o.centre = Vec3::Zero();
  o.feature_angle = 180;
  const Field field = [&] {
    Field f = Field::prepare(wrench, o);
    SigmaSpec c;
    c.axis.push_back({Vec3::UnitX(), Vec3::Zero(), 0.03, 1.0, 0.003});
    f.set_sigma(c);
    return f;
  }();
  EXPECT_GT(field.stats().n_verts, 1000);
  const auto points = field.boundary_points();
  int hint = -1;
  for (size_t b = 0; b < points.size(); b += 7) {
    const Sample q = field.query(points[b], &hint);
    ASSERT_EQ(q.status, Status::ok);
    EXPECT_NEAR(q.h, field.boundary_sigma()[static_cast<Eigen::Index>(b)], 1e-9);
  }
  // Ends allowed (σ ≈ +1), handle not (σ ≈ −1): h is lower above the handle than beyond the ends.
  EXPECT_LT(field.query(Vec3(0, 0, 0.01)).h, field.query(Vec3(0.06, 0, 0)).h);
  EXPECT_EQ(field.query(Vec3(0, 0, 0)).status, Status::inside);
}
