// Preparation: refused inputs, progress and cancellation, and the cache round trip.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "distlab/geometry/error.hpp"
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
