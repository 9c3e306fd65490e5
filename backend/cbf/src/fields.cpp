#include "distlab/cbf/fields.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "distlab/geometry/error.hpp"

namespace distlab::cbf {
namespace {

// Where the ray from the shape's centre along unit d leaves it (shape frame).
Vec3 surface_along(const Shape& shape, const Vec3& d) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const auto slab = [](double half, double component) { return component != 0 ? half / std::abs(component) : inf; };
  if (const auto* box = std::get_if<Box>(&shape))
    return d * std::min({slab(box->size.x() / 2, d.x()), slab(box->size.y() / 2, d.y()), slab(box->size.z() / 2, d.z())});
  if (const auto* s = std::get_if<Sphere>(&shape)) return d * s->radius;
  if (const auto* c = std::get_if<Cylinder>(&shape))
    return d * std::min(slab(c->radius, std::hypot(d.x(), d.y())), slab(c->height / 2, d.z()));
  if (const auto* c = std::get_if<Capsule>(&shape)) {
    const double t = slab(c->radius, std::hypot(d.x(), d.y()));
    if (std::abs(t * d.z()) <= c->height / 2) return d * t;
    const Vec3 cap(0, 0, std::copysign(c->height / 2, d.z()));  // |t d − cap| = r, the far root
    const double dc = d.dot(cap);
    return d * (dc + std::sqrt(dc * dc - cap.squaredNorm() + c->radius * c->radius));
  }
  const auto& p = std::get<Polytope>(shape);
  Vec3 centre = Vec3::Zero();
  for (const Vec3& v : p.vertices) centre += v;
  centre /= static_cast<double>(p.vertices.size());
  double t = inf;
  for (int i = 0; i < p.rows(); ++i) {
    const double ad = p.A.row(i).dot(d);
    if (ad > 0) t = std::min(t, (p.b[i] - p.A.row(i).dot(centre)) / ad);
  }
  return centre + t * d;
}

Vec3 fibonacci_direction(int i, int n) {
  const double z = 1 - (2.0 * i + 1) / n, r = std::sqrt(std::max(0.0, 1 - z * z));
  const double phi = i * std::numbers::pi * (3 - std::sqrt(5.0));  // the golden angle
  return {r * std::cos(phi), r * std::sin(phi), z};
}

}  // namespace

std::vector<ControlPoint> sample_control_points(const robot::Robot& robot, const std::string& link,
                                                const std::string& element, int count, const std::string& field) {
  const int l = robot.link_index(link);
  if (l < 0) throw InvalidInput(field + ".link", "no link \"" + link + "\" in robot \"" + robot.name() + "\"");
  if (count < 1) throw InvalidInput(field + ".sample", "sample must be a count >= 1");
  std::vector<const robot::LinkPrimitive*> elements;
  for (const auto& p : robot.primitives())
    if (p.link == l && (element.empty() || p.name == element)) elements.push_back(&p);
  if (elements.empty())
    throw InvalidInput(element.empty() ? field + ".link" : field + ".element",
                       element.empty() ? "link \"" + link + "\" has no collision elements to sample"
                                       : "link \"" + link + "\" has no collision element \"" + element + "\"");
  std::vector<ControlPoint> out;
  std::string prefix = link;
  if (!element.empty()) prefix.append("/").append(element);
  prefix += "#";
  const int per = count / static_cast<int>(elements.size()), extra = count % static_cast<int>(elements.size());
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const int n = per + (static_cast<int>(e) < extra ? 1 : 0);
    for (int i = 0; i < n; ++i) {
      const Vec3 local = surface_along(elements[e]->shape, fibonacci_direction(i, n));
      out.push_back({prefix + std::to_string(out.size()), l, elements[e]->pose.to_world(local)});
    }
  }
  return out;
}

void require_defined(const std::vector<FieldPointSample>& samples, const std::vector<SceneField>& fields,
                     const std::vector<ControlPoint>& points) {
  for (std::size_t r = 0; r < samples.size(); ++r)
    if (samples[r].status != kelvin::Status::ok)
      throw FieldUndefined("control point \"" + points[r % points.size()].name + "\" is " +
                           (samples[r].status == kelvin::Status::inside ? "inside the object of field \""
                                                                        : "where the discrete field is not positive, field \"") +
                           fields[r / points.size()].name + "\": h and its gradient do not exist there");
}

FieldBarrier::FieldBarrier(std::vector<SceneField> fields, std::vector<ControlPoint> points)
    : fields_(std::move(fields)), points_(std::move(points)) {
  reset_hints();
}

void FieldBarrier::reset_hints() { hints_.assign(static_cast<std::size_t>(rows()), -1); }

Vec3 FieldBarrier::world_point(const robot::Kinematics& k, int point) const {
  const ControlPoint& c = points_[static_cast<std::size_t>(point)];
  return k.R[static_cast<std::size_t>(c.link)] * c.point + k.frames[static_cast<std::size_t>(c.link)].position;
}

void FieldBarrier::evaluate(const robot::Robot& robot, const robot::Kinematics& k, std::vector<FieldPointSample>& samples,
                            Eigen::MatrixXd& grad_q, kelvin::Gradient kind) {
  const auto np = static_cast<int>(points_.size());
  samples.resize(static_cast<std::size_t>(rows()));
  grad_q.setZero(rows(), robot.dof());
  for (int p = 0; p < np; ++p) {
    const Vec3 x = world_point(k, p);
    robot.point_jacobian(k, points_[static_cast<std::size_t>(p)].link, x, J_);
    for (std::size_t f = 0; f < fields_.size(); ++f) {
      const SceneField& sf = fields_[f];
      const int r = static_cast<int>(f) * np + p;
      // h in the object's frame; its gradient is a covector, rotated back to the world.
      const kelvin::Sample s = sf.field->query(sf.pose.to_local(x), &hints_[static_cast<std::size_t>(r)], kind);
      FieldPointSample& out = samples[static_cast<std::size_t>(r)];
      out.h = s.h;
      out.status = s.status;
      out.gradient = sf.pose.dir_to_world(s.gradient);
      if (s.status == kelvin::Status::ok) grad_q.row(r) = out.gradient.transpose() * J_.topRows<3>();
    }
  }
}

FieldSurface::FieldSurface(const SceneField& field) : field_(field.field), sigma_(field.sigma), pose_(field.pose) {
  const mesh::SurfaceMesh& s = field_->surface();
  vertex_sigma_.resize(static_cast<std::size_t>(s.vertices.rows()));
  for (Eigen::Index v = 0; v < s.vertices.rows(); ++v)
    vertex_sigma_[static_cast<std::size_t>(v)] =
        kelvin::evaluate(sigma_, s.vertices.row(v).transpose(), sigma_.constant + (sigma_.per_vertex ? (*sigma_.per_vertex)[v] : 0.0));
  mesh::SurfaceMesh allowed{s.vertices, {}}, forbidden{s.vertices, {}};
  std::vector<Eigen::Index> a, b;
  for (Eigen::Index f = 0; f < s.faces.rows(); ++f) {
    double lo = INFINITY, hi = -INFINITY;
    for (int c = 0; c < 3; ++c) {
      const double v = vertex_sigma_[static_cast<std::size_t>(s.faces(f, c))];
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    if (lo > field.margin) a.push_back(f);
    if (hi < 0) b.push_back(f);
  }
  const auto subset = [&](const std::vector<Eigen::Index>& rows, mesh::SurfaceMesh& out) {
    out.faces.resize(static_cast<Eigen::Index>(rows.size()), 3);
    for (std::size_t i = 0; i < rows.size(); ++i) out.faces.row(static_cast<Eigen::Index>(i)) = s.faces.row(rows[i]);
  };
  subset(a, allowed);
  subset(b, forbidden);
  allowed_faces_ = static_cast<int>(a.size());
  forbidden_faces_ = static_cast<int>(b.size());
  all_ = std::make_unique<kelvin::SurfaceOracle>(s);
  if (!a.empty()) allowed_ = std::make_unique<kelvin::SurfaceOracle>(allowed);
  if (!b.empty()) forbidden_ = std::make_unique<kelvin::SurfaceOracle>(forbidden);
}

FieldSurface::~FieldSurface() = default;
FieldSurface::FieldSurface(FieldSurface&&) noexcept = default;
FieldSurface& FieldSurface::operator=(FieldSurface&&) noexcept = default;

double FieldSurface::sigma_at(const Vec3& object_point, int face, const Vec3& weights) const {
  const mesh::SurfaceMesh& s = field_->surface();
  double base = sigma_.constant;
  if (sigma_.per_vertex)
    for (int c = 0; c < 3; ++c) base += weights[c] * (*sigma_.per_vertex)[s.faces(face, c)];
  return kelvin::evaluate(sigma_, object_point, base);
}

double FieldSurface::forbidden_offset(double level, double step) const {
  const mesh::SurfaceMesh& s = field_->surface();
  double best = std::numeric_limits<double>::infinity();
  int hint = -1;
  for (Eigen::Index f = 0; f < s.faces.rows(); ++f) {
    if (!(std::max({vertex_sigma_[static_cast<std::size_t>(s.faces(f, 0))], vertex_sigma_[static_cast<std::size_t>(s.faces(f, 1))],
                    vertex_sigma_[static_cast<std::size_t>(s.faces(f, 2))]}) < 0))
      continue;
    const Vec3 a = s.vertices.row(s.faces(f, 0)), b = s.vertices.row(s.faces(f, 1)), c = s.vertices.row(s.faces(f, 2));
    const Vec3 centre = (a + b + c) / 3, n = (b - a).cross(c - a).normalized();
    const auto h = [&](double t) { return field_->query(centre + t * n, &hint, kelvin::Gradient::cell); };
    double lo = 0, hi = step;
    bool found = false, blocked = false;
    for (; hi < std::min(best, 1.0); lo = hi, hi += step) {
      const kelvin::Sample q = h(hi);
      if (q.status != kelvin::Status::ok) {
        blocked = true;
        break;
      }
      if (q.h >= level) {
        found = true;
        break;
      }
    }
    if (blocked || !found) continue;
    while (hi - lo > 1e-6) {
      const double mid = (lo + hi) / 2;
      const kelvin::Sample q = h(mid);
      (q.status == kelvin::Status::ok && q.h >= level ? hi : lo) = mid;
    }
    best = std::min(best, hi);
  }
  return best;
}

FieldContact FieldSurface::contact(const std::vector<Vec3>& world_points) const {
  FieldContact out;
  out.distance = std::numeric_limits<double>::infinity();
  int face = -1;
  Vec3 weights = Vec3::Zero();
  for (std::size_t p = 0; p < world_points.size(); ++p) {
    const Vec3 x = pose_.to_local(world_points[p]);
    const double d = all_->distance(x);
    if (d < out.distance) {
      out.distance = d;
      out.point = static_cast<int>(p);
    }
    if (allowed_) out.allowed_distance = std::min(out.allowed_distance, allowed_->distance(x));
    if (forbidden_) out.forbidden_distance = std::min(out.forbidden_distance, forbidden_->distance(x));
  }
  if (out.point < 0) return out;
  all_->closest(pose_.to_local(world_points[static_cast<std::size_t>(out.point)]), face, weights);
  const mesh::SurfaceMesh& s = field_->surface();
  Vec3 y = Vec3::Zero();
  for (int c = 0; c < 3; ++c) y += weights[c] * s.vertices.row(s.faces(face, c)).transpose();
  out.closest = pose_.to_world(y);
  out.sigma = sigma_at(y, face, weights);
  return out;
}

}  // namespace distlab::cbf
