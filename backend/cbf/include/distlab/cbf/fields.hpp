#pragma once
// The semantics-aware distance h of a Kelvin field (kelvin-semantics-aware-distance.txt) as a
// barrier of the CBF-QP: control points fixed to robot links keep h(x(q)) ≥ δ (the safe set of
// eq. 8–10 with α linear), through one row per field and point,
//   ∇h(x)ᵀ J_x(q) u ≥ −η (h(x) − δ),
// the time derivative of eq. 18 with σ quasi-static (∇_σ h σ̇ = 0) and J_x the point's linear
// velocity Jacobian. ∇h is the paper's smoothed gradient (continuous across cells, so the rows
// and u change continuously along a motion; the derivative of the interpolated h jumps at every
// cell face and makes u chatter). The two differ by O(l_x): test_fields.cpp checks the chain
// rule with kelvin::Gradient::cell against finite differences of h(x(q)), and the smoothed one
// against it.
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/surface_tools.hpp"
#include "distlab/robot/robot.hpp"

namespace distlab::cbf {

// A point fixed to a robot link.
struct ControlPoint {
  std::string name;
  int link = -1;              // index into Robot::links()
  Vec3 point = Vec3::Zero();  // in the link's frame
};

// `count` points on the surfaces of a link's collision elements (all of them, or the one named
// `element`), spread evenly over those elements in element order: on each, where rays from its
// centre along a spherical Fibonacci set of directions leave it (deterministic; the faces of a
// box get points in proportion to the solid angle they subtend). Names are LINK[/ELEMENT]#i.
// Throws InvalidInput(field) for an unknown link or element, a link without collision elements,
// or a count below 1 (the service bounds it: max_cbf_control_points).
std::vector<ControlPoint> sample_control_points(const robot::Robot& robot, const std::string& link,
                                                const std::string& element, int count, const std::string& field);

// A Kelvin object placed in the scene, its σ solved.
struct SceneField {
  std::string name;
  std::shared_ptr<const kelvin::Field> field;  // prepared; σ solved with vertex gradients
  kelvin::SigmaSpec sigma;                     // that σ, over field->surface()'s vertices
  Pose pose;                                   // object frame in the world
  double margin = 0;                           // δ of its rows (h is dimensionless)
};

// h at one control point (world gradient); status not ok: h and the gradient are NaN.
struct FieldPointSample {
  double h = std::numeric_limits<double>::quiet_NaN();
  Vec3 gradient = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  kelvin::Status status = kelvin::Status::ok;
};

// A row that cannot be formed: the control point is inside the object (or where the discrete V
// is not positive), so h and its gradient do not exist there. The message names both.
class FieldUndefined : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// Throws FieldUndefined for the first sample whose status is not ok.
void require_defined(const std::vector<FieldPointSample>& samples, const std::vector<SceneField>& fields,
                     const std::vector<ControlPoint>& points);

// The rows of every (field, control point), field-major: row f · points + p.
class FieldBarrier {
 public:
  FieldBarrier(std::vector<SceneField> fields, std::vector<ControlPoint> points);
  int rows() const { return static_cast<int>(fields_.size() * points_.size()); }
  const std::vector<SceneField>& fields() const { return fields_; }
  const std::vector<ControlPoint>& points() const { return points_; }
  // h and ∇_q h = ∇h(x)ᵀ J_x(q) of every row at kinematics k. Each row's cell search starts at its
  // previous cell (the paper's hint: sub-µs along a motion). grad_q gets rows() × dof.
  void evaluate(const robot::Robot& robot, const robot::Kinematics& k, std::vector<FieldPointSample>& samples,
                Eigen::MatrixXd& grad_q, kelvin::Gradient kind = kelvin::Gradient::smoothed);
  void reset_hints();
  Vec3 world_point(const robot::Kinematics& k, int point) const;

 private:
  std::vector<SceneField> fields_;
  std::vector<ControlPoint> points_;
  std::vector<int> hints_;
  robot::Jac J_;
};

// Where the control points are relative to one field's object surface (world units, metres):
// what a record shows and the outcomes of a semantic run are read from.
struct FieldContact {
  int point = -1;                                                       // the control point closest to the surface
  double distance = 0;                                                  // its Euclidean distance to the surface
  Vec3 closest = Vec3::Zero();                                          // the closest surface point (world)
  double sigma = 0;                                                     // σ there
  double allowed_distance = std::numeric_limits<double>::infinity();    // min over points, to faces with σ > δ at every corner
  double forbidden_distance = std::numeric_limits<double>::infinity();  // min over points, to faces with σ < 0 at every corner
};

// The object's surface split by σ, with closest-point queries (CGAL AABB trees).
class FieldSurface {
 public:
  explicit FieldSurface(const SceneField& field);
  ~FieldSurface();
  FieldSurface(FieldSurface&&) noexcept;
  FieldSurface& operator=(FieldSurface&&) noexcept;
  FieldContact contact(const std::vector<Vec3>& world_points) const;
  int allowed_faces() const { return allowed_faces_; }
  int forbidden_faces() const { return forbidden_faces_; }
  double sigma_at(const Vec3& object_point, int face, const Vec3& weights) const;  // σ at a surface point
  // The safety distance the field keeps from its forbidden faces: the smallest distance, along
  // the outward normal from a forbidden face's centre, to where h reaches `level` (the field's δ:
  // {h ≥ δ} starts there). Marched in steps of `step` then bisected to 1e-6 m; faces whose normal
  // line runs into the object again first are skipped. +inf without forbidden faces.
  double forbidden_offset(double level, double step) const;

 private:
  std::shared_ptr<const kelvin::Field> field_;
  kelvin::SigmaSpec sigma_;
  Pose pose_;
  std::vector<double> vertex_sigma_;
  std::unique_ptr<kelvin::SurfaceOracle> all_, allowed_, forbidden_;
  int allowed_faces_ = 0, forbidden_faces_ = 0;
};

}  // namespace distlab::cbf
