// FCL geometry for each distlab shape, built once.
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>

#include <cmath>
#include <vector>

#include "distlab/collision/euclidean.hpp"
#include "distlab/geometry/error.hpp"

namespace distlab {
namespace {

void require_positive(double x, const char* what) {
  if (!(std::isfinite(x) && x > 0))
    throw InvalidInput(std::string("shape.") + what, std::string(what) + " must be positive");
}

struct ToFcl {
  std::shared_ptr<fcl::CollisionGeometry<double>> operator()(const Box& b) const {
    for (int i = 0; i < 3; ++i) require_positive(b.size[i], "size");
    return std::make_shared<fcl::Boxd>(b.size.x(), b.size.y(), b.size.z());
  }
  std::shared_ptr<fcl::CollisionGeometry<double>> operator()(const Sphere& s) const {
    require_positive(s.radius, "radius");
    return std::make_shared<fcl::Sphered>(s.radius);
  }
  // FCL cylinders and capsules are centred with axis z, like distlab's. fcl::Capsule::lz is the
  // length of the core segment (its local AABB has half-height lz / 2 + radius), i.e. exactly
  // distlab's Capsule::height.
  std::shared_ptr<fcl::CollisionGeometry<double>> operator()(const Cylinder& c) const {
    require_positive(c.radius, "radius");
    require_positive(c.height, "height");
    return std::make_shared<fcl::Cylinderd>(c.radius, c.height);
  }
  std::shared_ptr<fcl::CollisionGeometry<double>> operator()(const Capsule& c) const {
    require_positive(c.radius, "radius");
    if (!(std::isfinite(c.height) && c.height >= 0))
      throw InvalidInput("shape.height", "height must be non-negative");
    return std::make_shared<fcl::Capsuled>(c.radius, c.height);
  }
  // fcl::Convex: shared vertices and faces as [n, i0, ..., i(n-1), n, ...].
  std::shared_ptr<fcl::CollisionGeometry<double>> operator()(const Polytope& p) const {
    if (p.vertices.size() < 4 || p.faces.empty())
      throw InvalidInput("shape", "polytope has no vertices or faces (use make_polytope)");
    auto verts = std::make_shared<std::vector<fcl::Vector3d>>(p.vertices.begin(), p.vertices.end());
    auto faces = std::make_shared<std::vector<int>>();
    faces->reserve(4 * p.faces.size());
    for (const Eigen::Vector3i& f : p.faces) faces->insert(faces->end(), {3, f[0], f[1], f[2]});
    return std::make_shared<fcl::Convexd>(verts, static_cast<int>(p.faces.size()), faces);
  }
};

}  // namespace

EuclideanShape::EuclideanShape(const Shape& shape)
    : shape_(std::make_shared<const Shape>(shape)), fcl_(std::visit(ToFcl{}, *shape_)) {
  fcl_->computeLocalAABB();
}

}  // namespace distlab
