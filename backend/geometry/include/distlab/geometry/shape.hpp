#pragma once
// The convex shapes distlab knows, each in its own frame. Round shapes are centred at the frame
// origin with their axis along local z.
#include <string>
#include <variant>

#include "distlab/geometry/polytope.hpp"
#include "distlab/geometry/pose.hpp"

namespace distlab {

struct Box {
  Vec3 size;  // full edge lengths x, y, z
};
struct Sphere {
  double radius;
};
struct Cylinder {
  double radius;
  double height;  // full length along z
};
struct Capsule {
  double radius;
  double height;  // length of the core segment along z (total length = height + 2 radius)
};

using Shape = std::variant<Polytope, Box, Sphere, Cylinder, Capsule>;

// A shape placed in the world.
struct Body {
  Shape shape;
  Pose pose;
};

std::string shape_type_name(const Shape& s);

// A ball (centre in the shape frame, radius) that contains the shape; tight for round shapes,
// the vertices' bounding-box centre and farthest vertex for polytopes.
struct Ball {
  Vec3 center;
  double radius;
};
Ball bounding_ball(const Shape& s);

// Support point in the shape frame: argmax over the shape of d . x (d need not be unit).
Vec3 support(const Shape& s, const Vec3& d);

// The half-spaces {x : A x <= b} of a box, unit rows (+x, -x, +y, -y, +z, -z).
void box_halfspaces(const Box& box, MatX3& A, VecX& b);

}  // namespace distlab
