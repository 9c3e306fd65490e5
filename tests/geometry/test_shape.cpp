// Support points, bounding balls, names and box half-spaces of every shape type.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "distlab/geometry/shape.hpp"

namespace distlab {
namespace {

std::mt19937 rng(2024);
std::normal_distribution<double> gauss;
std::uniform_real_distribution<double> unif(-1, 1);

Vec3 random_vec() { return Vec3(gauss(rng), gauss(rng), gauss(rng)); }

Polytope random_polytope() {
  std::vector<Vec3> pts;
  for (int i = 0; i < 30; ++i) pts.emplace_back(random_vec() + Vec3(0.5, -1, 2));
  return polytope_from_points(pts, "p");
}

// The test shapes: one of each type, not symmetric about all axes where possible.
std::vector<Shape> shapes() {
  return {random_polytope(), Box{Vec3(1, 2, 0.5)}, Sphere{0.7}, Cylinder{0.4, 1.5},
          Capsule{0.3, 1.2}};
}

// Signed amount by which x lies outside s (<= 0 inside), in the shape frame.
double outside(const Shape& s, const Vec3& x) {
  if (auto* p = std::get_if<Polytope>(&s)) return (p->A * x - p->b).maxCoeff();
  if (auto* b = std::get_if<Box>(&s)) return (x.cwiseAbs() - 0.5 * b->size).maxCoeff();
  if (auto* sp = std::get_if<Sphere>(&s)) return x.norm() - sp->radius;
  if (auto* c = std::get_if<Cylinder>(&s))
    return std::max(std::hypot(x.x(), x.y()) - c->radius, std::abs(x.z()) - 0.5 * c->height);
  const auto& c = std::get<Capsule>(s);
  const double z = std::clamp(x.z(), -0.5 * c.height, 0.5 * c.height);
  return (x - Vec3(0, 0, z)).norm() - c.radius;
}

// Points spread through the shape (rejection from the bounding ball, plus polytope vertices).
std::vector<Vec3> samples_inside(const Shape& s) {
  const Ball ball = bounding_ball(s);
  std::vector<Vec3> out;
  while (out.size() < 2000) {
    const Vec3 x = ball.center + ball.radius * Vec3(unif(rng), unif(rng), unif(rng));
    if (outside(s, x) <= 0) out.push_back(x);
  }
  if (auto* p = std::get_if<Polytope>(&s)) out.insert(out.end(), p->vertices.begin(), p->vertices.end());
  return out;
}

// The exact support value max_x d . x for the round shapes and the box.
double support_value(const Shape& s, const Vec3& d) {
  if (auto* b = std::get_if<Box>(&s)) return 0.5 * b->size.dot(d.cwiseAbs());
  if (auto* sp = std::get_if<Sphere>(&s)) return sp->radius * d.norm();
  if (auto* c = std::get_if<Cylinder>(&s))
    return c->radius * std::hypot(d.x(), d.y()) + 0.5 * c->height * std::abs(d.z());
  if (auto* c = std::get_if<Capsule>(&s)) return c->radius * d.norm() + 0.5 * c->height * std::abs(d.z());
  return NAN;
}

TEST(Shape, Names) {
  const char* names[] = {"polytope", "box", "sphere", "cylinder", "capsule"};
  const auto all = shapes();
  for (std::size_t i = 0; i < all.size(); ++i) EXPECT_EQ(shape_type_name(all[i]), names[i]);
}

TEST(Shape, SupportIsOnTheShapeAndMaximal) {
  for (const Shape& s : shapes()) {
    SCOPED_TRACE(shape_type_name(s));
    const std::vector<Vec3> inside = samples_inside(s);
    for (int k = 0; k < 200; ++k) {
      const Vec3 d = random_vec() * std::pow(10.0, k % 7 - 3);  // d need not be unit
      const Vec3 p = support(s, d);
      EXPECT_LE(outside(s, p), 1e-12);
      for (const Vec3& x : inside) ASSERT_GE(p.dot(d), x.dot(d) - 1e-12 * d.norm());
      const double h = support_value(s, d);
      if (!std::isnan(h)) {
        EXPECT_NEAR(p.dot(d), h, 1e-12 * d.norm());
      }
    }
  }
}

TEST(Shape, SupportAlongAxesAndDegenerateDirections) {
  for (const Shape& s : shapes()) {
    SCOPED_TRACE(shape_type_name(s));
    for (const Vec3& d : {Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(0, -1e-300, 0),
                          Vec3(1e-310, 0, 0), Vec3(1e300, 1e300, 0)}) {
      const Vec3 p = support(s, d);
      ASSERT_TRUE(p.allFinite()) << d.transpose();
      EXPECT_LE(outside(s, p), 1e-12) << d.transpose();
      const double h = support_value(s, d);
      if (!std::isnan(h)) {
        EXPECT_NEAR(p.dot(d), h, 1e-12 * d.norm() + 1e-300);
      }
    }
  }
  // Known points.
  EXPECT_TRUE(support(Box{Vec3(2, 4, 6)}, Vec3(1, -1, 1)).isApprox(Vec3(1, -2, 3)));
  EXPECT_TRUE(support(Cylinder{1, 2}, Vec3(0, 3, -1)).isApprox(Vec3(0, 1, -1)));
  EXPECT_TRUE(support(Capsule{1, 2}, Vec3(0, 0, 5)).isApprox(Vec3(0, 0, 2)));
  EXPECT_TRUE(support(Sphere{2}, Vec3(3, 4, 0)).isApprox(Vec3(1.2, 1.6, 0)));
}

TEST(Shape, BoundingBallContainsTheShape) {
  for (const Shape& s : shapes()) {
    SCOPED_TRACE(shape_type_name(s));
    const Ball ball = bounding_ball(s);
    for (int k = 0; k < 2000; ++k)
      EXPECT_LE((support(s, random_vec()) - ball.center).norm(), ball.radius * (1 + 1e-12));
    if (auto* p = std::get_if<Polytope>(&s)) {
      double farthest = 0;
      for (const Vec3& v : p->vertices) farthest = std::max(farthest, (v - ball.center).norm());
      EXPECT_DOUBLE_EQ(farthest, ball.radius);  // the farthest vertex defines it
    }
  }
  // Tight for the round shapes and the box.
  EXPECT_DOUBLE_EQ(bounding_ball(Sphere{0.7}).radius, 0.7);
  EXPECT_DOUBLE_EQ(bounding_ball(Box{Vec3(2, 3, 6)}).radius, 3.5);
  EXPECT_DOUBLE_EQ(bounding_ball(Cylinder{3, 8}).radius, 5.0);
  EXPECT_DOUBLE_EQ(bounding_ball(Capsule{1, 4}).radius, 3.0);
  const Ball pb = bounding_ball(polytope_from_points(
      {{0, 0, 0}, {2, 0, 0}, {0, 4, 0}, {0, 0, 6}}, "p"));
  EXPECT_TRUE(pb.center.isApprox(Vec3(1, 2, 3)));
  EXPECT_DOUBLE_EQ(pb.radius, std::sqrt(14.0));
}

TEST(Shape, BoxHalfspaces) {
  MatX3 A;
  VecX b;
  box_halfspaces(Box{Vec3(2, 4, 6)}, A, b);
  MatX3 expected_A(6, 3);
  expected_A << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
  EXPECT_EQ(A, expected_A);
  EXPECT_EQ(b, (VecX(6) << 1, 1, 2, 2, 3, 3).finished());
}

}  // namespace
}  // namespace distlab
