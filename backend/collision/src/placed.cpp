// Inside tests of the distlab shapes in their own frames.
#include "placed.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace distlab::detail {

double inside_violation(const Shape& s, const Vec3& p) {
  struct Visitor {
    const Vec3& p;
    double operator()(const Polytope& q) const {
      double v = -std::numeric_limits<double>::infinity();
      for (int i = 0; i < q.rows(); ++i) v = std::max(v, q.A.row(i).dot(p) - q.b[i]);
      return v;
    }
    double operator()(const Box& b) const { return (p.cwiseAbs() - 0.5 * b.size).maxCoeff(); }
    double operator()(const Sphere& b) const { return p.norm() - b.radius; }
    double operator()(const Cylinder& c) const {
      return std::max(std::hypot(p.x(), p.y()) - c.radius, std::abs(p.z()) - 0.5 * c.height);
    }
    double operator()(const Capsule& c) const {
      const double z = std::clamp(p.z(), -0.5 * c.height, 0.5 * c.height);
      return (p - Vec3(0, 0, z)).norm() - c.radius;
    }
  };
  return std::visit(Visitor{p}, s);
}

}  // namespace distlab::detail
