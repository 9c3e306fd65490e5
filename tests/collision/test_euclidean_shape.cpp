// FCL geometry built by EuclideanShape: types, parameters and conventions.
#include <gtest/gtest.h>

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>

#include "collision/collision_test_util.hpp"
#include "distlab/geometry/error.hpp"

namespace distlab {
namespace {

template <class T>
const T& as(const EuclideanShape& e) {
  const auto* p = dynamic_cast<const T*>(e.fcl_geometry().get());
  EXPECT_NE(p, nullptr);
  return *p;
}

TEST(EuclideanShape, PrimitiveParameters) {
  EXPECT_EQ(as<fcl::Boxd>(EuclideanShape(Box{Vec3(1, 2, 3)})).side, Vec3(1, 2, 3));
  EXPECT_EQ(as<fcl::Sphered>(EuclideanShape(Sphere{0.7})).radius, 0.7);
  const EuclideanShape ec(Cylinder{0.4, 1.2}), ek(Capsule{0.3, 1.0});
  const auto& cyl = as<fcl::Cylinderd>(ec);
  EXPECT_EQ(cyl.radius, 0.4);
  EXPECT_EQ(cyl.lz, 1.2);
  const auto& cap = as<fcl::Capsuled>(ek);
  EXPECT_EQ(cap.radius, 0.3);
  EXPECT_EQ(cap.lz, 1.0);
}

// fcl::Capsule::lz is the core segment, like distlab's height: a sphere just above the tip.
TEST(EuclideanShape, CapsuleLengthConvention) {
  const EuclideanShape cap(Capsule{0.3, 1.0}), ball(Sphere{0.1});
  Pose above;
  above.position = Vec3(0, 0, 0.5 + 0.3 + 0.1 + 0.25);
  EXPECT_NEAR(euclidean_distance(cap, Pose{}, ball, above).distance, 0.25, 1e-12);
  const EuclideanShape cyl(Cylinder{0.3, 1.0});
  EXPECT_NEAR(euclidean_distance(cyl, Pose{}, ball, above).distance, 0.25 + 0.3, 1e-12);
}

TEST(EuclideanShape, PolytopeBecomesConvex) {
  const Polytope p = test::ten_row_polytope();
  const EuclideanShape e(p);
  const auto& c = as<fcl::Convexd>(e);
  EXPECT_EQ(c.getVertices().size(), p.vertices.size());
  EXPECT_EQ(c.getFaceCount(), static_cast<int>(p.faces.size()));
  for (std::size_t i = 0; i < p.vertices.size(); ++i) EXPECT_EQ(c.getVertices()[i], p.vertices[i]);
}

TEST(EuclideanShape, KeepsTheShape) {
  const EuclideanShape e(Capsule{0.3, 1.0});
  ASSERT_TRUE(std::holds_alternative<Capsule>(e.shape()));
  EXPECT_EQ(std::get<Capsule>(e.shape()).height, 1.0);
}

TEST(EuclideanShape, RejectsBadSizes) {
  EXPECT_THROW(EuclideanShape(Sphere{0}), InvalidInput);
  EXPECT_THROW(EuclideanShape(Box{Vec3(1, -1, 1)}), InvalidInput);
  EXPECT_THROW(EuclideanShape(Cylinder{0.1, std::nan("")}), InvalidInput);
  EXPECT_THROW(EuclideanShape(Polytope{}), InvalidInput);
}

}  // namespace
}  // namespace distlab
