// The level-set numerics behind /api/gap/levelsets: marching tetrahedra on analytic fields and
// e_S / E_S iso-surfaces of GAP shapes.
#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>

#include "distlab/gap/point_to_set.hpp"
#include "distlab/geometry/error.hpp"
#include "distlab/levelset/gap_fields.hpp"
#include "distlab/levelset/grid.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/surface.hpp"

namespace distlab::levelset {
namespace {

TEST(Levelset, SphereIsClosedOrientedAndAccurate) {
  const levelset::MultiField f = [](const Vec3& x, double* v) { v[0] = x.norm(); };
  const auto grids = sample_grid(f, 1, Vec3::Constant(-1), Vec3::Constant(1), {41, 41, 41});
  const mesh::SurfaceMesh m = marching_tetrahedra(grids[0], 0.6);
  ASSERT_GT(m.faces.rows(), 500);
  EXPECT_EQ(mesh::topology_defect(m), "");
  const double volume = mesh::signed_volume(m);  // outward = towards increasing |x|
  EXPECT_NEAR(volume, 4.0 / 3.0 * M_PI * 0.216, 0.02);
  for (Eigen::Index i = 0; i < m.vertices.rows(); ++i) EXPECT_NEAR(m.vertices.row(i).norm(), 0.6, 0.01);
}

TEST(Levelset, EmptyAndCutSurfaces) {
  const levelset::MultiField f = [](const Vec3& x, double* v) { v[0] = x.z(); };
  const auto grids = sample_grid(f, 1, Vec3::Constant(-1), Vec3::Constant(1), {5, 5, 5});
  EXPECT_EQ(marching_tetrahedra(grids[0], 5.0).faces.rows(), 0);
  const auto plane = marching_tetrahedra(grids[0], 0.25);
  ASSERT_GT(plane.faces.rows(), 0);
  for (Eigen::Index i = 0; i < plane.vertices.rows(); ++i) EXPECT_NEAR(plane.vertices(i, 2), 0.25, 1e-12);
  EXPECT_THROW(sample_grid(f, 1, Vec3::Constant(1), Vec3::Constant(-1), {5, 5, 5}), InvalidInput);
  EXPECT_THROW(sample_grid(f, 1, Vec3::Constant(-1), Vec3::Constant(1), {1, 5, 5}), InvalidInput);
}

TEST(Levelset, GapBoxLevelsMatchTheField) {
  const Shape box = Box{Vec3(1.0, 0.6, 0.4)};
  PointToSet p2s(box, BaseFunction(0.1, 2), StrictParams{}, P2SOptions{}, "shape");
  Pose pose;
  pose.position = Vec3(0.5, -0.2, 0.1);
  p2s.set_pose(pose);
  GapLevelsetOptions o;
  o.weak_levels = {0.1};
  o.strict_levels = {0.05};
  o.resolution = 40;
  o.plane = plane_from_normal(pose.position, Vec3::UnitZ(), 2, 2, 16, 16);
  const GapLevelsets r = gap_levelsets(p2s, o);
  ASSERT_EQ(r.surfaces.size(), 2u);
  for (const auto& s : r.surfaces) {
    ASSERT_GT(s.mesh.faces.rows(), 100);
    EXPECT_EQ(mesh::topology_defect(s.mesh), "") << (s.strict ? "strict" : "weak");
    EXPECT_GT(mesh::signed_volume(s.mesh), 0.24);  // encloses the box
    double worst = 0;
    for (Eigen::Index i = 0; i < s.mesh.vertices.rows(); ++i) {
      const Vec3 x = s.mesh.vertices.row(i).transpose();
      const double v = s.strict ? p2s.strict(x, 0).value : p2s.weak(x, 0).value;
      worst = std::max(worst, std::abs(v - s.level) / s.level);
    }
    EXPECT_LT(worst, 0.1) << (s.strict ? "strict" : "weak");
  }
  ASSERT_EQ(r.plane_weak.size(), 256u);
  EXPECT_EQ(r.plane_weak[0], p2s.weak(o.plane->centre - o.plane->u - o.plane->v, 0).value);
  std::atomic<bool> cancel{true};
  Progress cancelled;
  cancelled.cancel = &cancel;
  EXPECT_THROW(gap_levelsets(p2s, o, cancelled), Cancelled);
  // What the report throws (a request's time limit) stops the work and leaves gap_levelsets.
  std::atomic<int> reports{0};
  Progress late;
  late.report = [&reports](const std::string& stage, double fraction) {
    EXPECT_TRUE(stage == "sample" || stage == "mesh");
    EXPECT_TRUE(fraction >= 0 && fraction < 1);
    if (++reports == 5) throw std::out_of_range("late");
  };
  EXPECT_THROW(gap_levelsets(p2s, o, late), std::out_of_range);
  EXPECT_GE(reports.load(), 5);
  o.weak_levels = {-1};
  EXPECT_THROW(gap_levelsets(p2s, o), InvalidInput);
}

}  // namespace
}  // namespace distlab::levelset
