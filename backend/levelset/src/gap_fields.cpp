// e_S / E_S level sets of one shape.
#include "distlab/levelset/gap_fields.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "distlab/geometry/error.hpp"

namespace distlab::levelset {
namespace {

void check_levels(const std::vector<double>& levels, const std::string& field) {
  for (std::size_t i = 0; i < levels.size(); ++i)
    if (!std::isfinite(levels[i]) || levels[i] <= 0)
      throw InvalidInput(field + "[" + std::to_string(i) + "]",
                         "levels must be positive and finite (both fields are 0 on the shape)");
}

}  // namespace

GapLevelsets gap_levelsets(const PointToSet& p2s, const GapLevelsetOptions& o, const Progress& progress) {
  check_levels(o.weak_levels, "levels.weak");
  check_levels(o.strict_levels, "levels.strict");
  if (o.resolution < 4) throw InvalidInput("grid.resolution", "grid.resolution must be at least 4");
  if (!(o.padding >= 0) || !std::isfinite(o.padding)) throw InvalidInput("grid.padding", "grid.padding must be >= 0");

  GapLevelsets out;
  if (o.bounds) {
    out.lo = o.bounds->first;
    out.hi = o.bounds->second;
    if (!((out.hi - out.lo).minCoeff() > 0)) throw InvalidInput("grid.bounds", "grid.bounds must have max > min on every axis");
  } else {
    const Ball ball = bounding_ball(p2s.shape());
    const Vec3 c = p2s.pose().to_world(ball.center);
    double r = ball.radius * (1.0 + o.padding);
    // Grow the box until the largest requested level set fits: e_S and E_S grow more slowly
    // than the Euclidean distance, so a fixed padding would cut large levels open.
    double weak_max = 0, strict_max = 0;
    for (double l : o.weak_levels) weak_max = std::max(weak_max, l);
    for (double l : o.strict_levels) strict_max = std::max(strict_max, l);
    for (int grow = 0; grow < 12; ++grow) {
      double weak_min = INFINITY, strict_min = INFINITY;
      for (int a = 0; a < 3; ++a)
        for (double sign : {-1.0, 1.0}) {
          const Vec3 x = c + sign * r * Vec3::Unit(a);
          weak_min = std::min(weak_min, p2s.weak(x, 0).value);
          strict_min = std::min(strict_min, p2s.strict(x, 0).value);
        }
      if (weak_min > 1.05 * weak_max && strict_min > 1.05 * strict_max) break;
      r *= 1.3;
    }
    out.lo = c - Vec3::Constant(r);
    out.hi = c + Vec3::Constant(r);
  }
  const Vec3 extent = out.hi - out.lo;
  const double step = extent.maxCoeff() / (o.resolution - 1);
  for (int a = 0; a < 3; ++a) out.n[a] = std::max(2, static_cast<int>(std::ceil(extent[a] / step - 1e-9)) + 1);

  const MultiField both = [&p2s](const Vec3& x, double* v) {
    v[0] = p2s.weak(x, 0).value;
    v[1] = p2s.strict(x, 0).value;
  };
  if (!o.weak_levels.empty() || !o.strict_levels.empty()) {
    const std::vector<Grid> grids = sample_grid(both, 2, out.lo, out.hi, out.n, o.threads, progress);
    const double levels = static_cast<double>(o.weak_levels.size() + o.strict_levels.size());
    for (double level : o.weak_levels) {
      progress("mesh", static_cast<double>(out.surfaces.size()) / levels);
      out.surfaces.push_back({false, level, marching_tetrahedra(grids[0], level)});
    }
    for (double level : o.strict_levels) {
      progress("mesh", static_cast<double>(out.surfaces.size()) / levels);
      out.surfaces.push_back({true, level, marching_tetrahedra(grids[1], level)});
    }
  }
  if (o.plane) {
    auto planes = sample_plane(both, 2, *o.plane, o.threads);
    out.plane_weak = std::move(planes[0]);
    out.plane_strict = std::move(planes[1]);
  }
  return out;
}

}  // namespace distlab::levelset
