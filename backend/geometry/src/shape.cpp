// Names, bounding balls and support points of the shape variants.
#include "distlab/geometry/shape.hpp"
#include "distlab/geometry/overloaded.hpp"

#include <algorithm>
#include <cmath>

namespace distlab {
namespace {

// d scaled to unit length, or zero when d is zero (stableNorm: no underflow for tiny d).
Vec3 unit_or_zero(const Vec3& d) {
  const double n = d.stableNorm();
  return n > 0 ? Vec3(d / n) : Vec3::Zero();
}

// Point of a disc of radius r in the z = 0 plane that is farthest along (dx, dy).
Vec3 disc_support(double r, double dx, double dy) {
  const double n = std::hypot(dx, dy);
  return n > 0 ? Vec3(r * dx / n, r * dy / n, 0) : Vec3::Zero();
}

}  // namespace

std::string shape_type_name(const Shape& s) {
  return std::visit(Overloaded{[](const Polytope&) { return "polytope"; },
                               [](const Box&) { return "box"; },
                               [](const Sphere&) { return "sphere"; },
                               [](const Cylinder&) { return "cylinder"; },
                               [](const Capsule&) { return "capsule"; }},
                    s);
}

Ball bounding_ball(const Shape& s) {
  return std::visit(
      Overloaded{[](const Polytope& p) {
                   if (p.vertices.empty()) return Ball{Vec3::Zero(), 0.0};
                   Vec3 lo = p.vertices[0], hi = p.vertices[0];
                   for (const Vec3& v : p.vertices) {
                     lo = lo.cwiseMin(v);
                     hi = hi.cwiseMax(v);
                   }
                   const Vec3 c = 0.5 * (lo + hi);
                   double r = 0;
                   for (const Vec3& v : p.vertices) r = std::max(r, (v - c).norm());
                   return Ball{c, r};
                 },
                 [](const Box& b) { return Ball{Vec3::Zero(), 0.5 * b.size.norm()}; },
                 [](const Sphere& b) { return Ball{Vec3::Zero(), b.radius}; },
                 [](const Cylinder& c) {
                   return Ball{Vec3::Zero(), std::hypot(c.radius, 0.5 * c.height)};
                 },
                 [](const Capsule& c) { return Ball{Vec3::Zero(), c.radius + 0.5 * c.height}; }},
      s);
}

Vec3 support(const Shape& s, const Vec3& d) {
  // Ties (zero components of d) go to the + side: any maximiser is a valid answer.
  const auto side = [](double x) { return x < 0 ? -1.0 : 1.0; };
  return std::visit(
      Overloaded{[&](const Polytope& p) {
                   if (p.vertices.empty()) return Vec3(Vec3::Zero());
                   // One dot product per vertex (GJK calls this in its inner loop); the first
                   // maximiser wins, as with std::max_element.
                   // Selects without a branch: the running maximum changes at random
                   // vertices, and each change was a mispredicted jump.
                   size_t best = 0;
                   double best_dot = d.dot(p.vertices[0]);
                   for (size_t i = 1; i < p.vertices.size(); ++i) {
                     const double v = d.dot(p.vertices[i]);
                     const bool more = v > best_dot;
                     best = more ? i : best;
                     best_dot = more ? v : best_dot;
                   }
                   return p.vertices[best];
                 },
                 [&](const Box& b) {
                   const Vec3 h = 0.5 * b.size;
                   return Vec3(side(d.x()) * h.x(), side(d.y()) * h.y(), side(d.z()) * h.z());
                 },
                 [&](const Sphere& b) { return Vec3(b.radius * unit_or_zero(d)); },
                 [&](const Cylinder& c) {
                   return Vec3(disc_support(c.radius, d.x(), d.y()) +
                               Vec3(0, 0, side(d.z()) * 0.5 * c.height));
                 },
                 [&](const Capsule& c) {
                   return Vec3(c.radius * unit_or_zero(d) + Vec3(0, 0, side(d.z()) * 0.5 * c.height));
                 }},
      s);
}

void box_halfspaces(const Box& box, MatX3& A, VecX& b) {
  A.resize(6, 3);
  b.resize(6);
  for (int axis = 0; axis < 3; ++axis) {
    for (int sign = 0; sign < 2; ++sign) {
      const int row = 2 * axis + sign;
      A.row(row).setZero();
      A(row, axis) = sign == 0 ? 1.0 : -1.0;
      b[row] = 0.5 * box.size[axis];
    }
  }
}

}  // namespace distlab
