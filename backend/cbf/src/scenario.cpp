#include "distlab/cbf/scenario.hpp"

#include <cmath>
#include <numbers>

#include "distlab/geometry/error.hpp"

namespace distlab::cbf {

const char* to_string(GapMode m) { return m == GapMode::exact ? "exact" : "as_published"; }

int Scenario::steps() const { return static_cast<int>(std::lround(duration / dt)); }

Scenario corridor_narrow_scenario(std::shared_ptr<const Robot> panda) {
  constexpr double pi = std::numbers::pi;
  Scenario s;
  s.name = "corridor_narrow";
  s.robot = std::move(panda);
  auto box = [](const char* name, const Vec3& c, const Vec3& size) {
    Obstacle o{name, Box{size}, Pose{}, P2SOptions{}};
    o.pose.position = c;
    return o;
  };
  s.obstacles = {box("wall1", {0.53, 0.16, 0.45}, {0.35, 0.05, 0.90}),
                 box("wall2", {0.53, -0.16, 0.45}, {0.35, 0.05, 0.90}),
                 box("roof", {0.53, 0, 0.925}, {0.35, 0.35, 0.05})};
  s.target.position = Vec3(0.64, 0, 0.75);
  s.target.rotation = Quat(Eigen::AngleAxisd(pi / 2, Vec3::UnitY())) *
                      Quat(Eigen::AngleAxisd(pi / 2, Vec3::UnitZ()));
  s.q0.resize(7);
  s.q0 << 1.0582, -1.3811, 0.3629, -1.9647, -0.959, 1.4881, -0.1534;
  return s;
}

namespace {

void positive(double v, const std::string& field, double upper = INFINITY) {
  if (!std::isfinite(v) || !(v > 0) || !(v < upper))
    throw InvalidInput(field, field + " must be finite, > 0" +
                                  (std::isfinite(upper) ? " and < " + std::to_string(upper) : "") +
                                  ", got " + std::to_string(v));
}
void nonnegative(double v, const std::string& field) {
  if (!std::isfinite(v) || v < 0)
    throw InvalidInput(field, field + " must be finite and >= 0, got " + std::to_string(v));
}

}  // namespace

void validate(const Scenario& s) {
  positive(s.dt, "dt", 1.0);
  positive(s.duration, "duration", 3600.0);
  if (s.steps() < 1 || s.steps() > 1'000'000)
    throw InvalidInput("duration", "duration / dt must give 1 to 1000000 steps");
  positive(s.task_gain, "task_gain");
  positive(s.damping, "damping");
  positive(s.eta, "eta");
  positive(s.eta_joint, "eta_joint");
  // Named by their path in a scenario's JSON ("margins": {"gap": {...}, "euclidean": {...}}).
  nonnegative(s.gap_margins.obstacle, "margins.gap.obstacle");
  nonnegative(s.gap_margins.self, "margins.gap.self");
  nonnegative(s.euclidean_margins.obstacle, "margins.euclidean.obstacle");
  nonnegative(s.euclidean_margins.self, "margins.euclidean.self");
  positive(s.goal_tolerance, "goal_tolerance");
  positive(s.slack_weight, "slack_weight");
  try {
    check_params(s.gap);
  } catch (const InvalidInput& e) {  // "params.h" -> "gap.h"
    const std::string& f = e.field();
    throw InvalidInput(f.rfind("params.", 0) == 0 ? "gap." + f.substr(7) : f, e.what());
  }
  if (s.gap_mode == GapMode::as_published && s.gap.max_iter < 1)
    throw InvalidInput("gap.max_iter",
                       "gap.mode \"as_published\" needs gap.max_iter >= 1 (its "
                       "iteration cap, e.g. 20 on the real robot, 300 in simulation)");
  if (!s.robot) throw InvalidInput("robot", "no robot");
  const Robot& robot = *s.robot;
  const int dof = robot.dof();
  if (s.q0.size() != dof)
    throw InvalidInput("q0", "q0 needs " + std::to_string(dof) + " entries (robot \"" + robot.name() +
                                 "\"), got " + std::to_string(s.q0.size()));
  if (s.velocity_limit.size() != 0 && s.velocity_limit.size() != dof)
    throw InvalidInput("velocity_limit", "velocity_limit needs " + std::to_string(dof) + " entries");
  for (int i = 0; i < s.velocity_limit.size(); ++i) {
    const std::string f = "velocity_limit[" + std::to_string(i) + "]";
    if (std::isnan(s.velocity_limit[i]) || !(s.velocity_limit[i] > 0))
      throw InvalidInput(f, f + " must be > 0 (or absent: no limit), got " +
                                std::to_string(s.velocity_limit[i]));
  }
  if (dof < 1) throw InvalidInput("robot", "the CBF controller needs a robot with at least one moving joint");
  for (int i = 0; i < dof; ++i)
    if (!std::isfinite(robot.q_min()[i]) || !std::isfinite(robot.q_max()[i]))
      throw InvalidInput("robot", "the CBF controller needs every joint bounded: joint \"" + robot.joint_names()[i] +
                                      "\" has no finite limits (continuous)");
  for (int i = 0; i < dof; ++i) {
    const std::string f = "q0[" + std::to_string(i) + "]";
    if (!std::isfinite(s.q0[i]))
      throw InvalidInput(f, f + " must be finite");
    if (s.q0[i] < robot.q_min()[i] || s.q0[i] > robot.q_max()[i])
      throw InvalidInput(f, f + " = " + std::to_string(s.q0[i]) + " is outside the joint limits [" +
                                std::to_string(robot.q_min()[i]) + ", " +
                                std::to_string(robot.q_max()[i]) + "]");
  }
  if (s.fields.empty() != s.control_points.empty())
    throw InvalidInput(s.fields.empty() ? "control_points" : "fields",
                       "fields and control_points go together: a field constrains the control points, and "
                       "control points without a field constrain nothing");
  for (std::size_t i = 0; i < s.fields.size(); ++i) {
    const std::string f = "fields[" + std::to_string(i) + "]";
    if (!s.fields[i].field) throw InvalidInput(f, f + " has no prepared field");
    if (!std::isfinite(s.fields[i].margin)) throw InvalidInput(f + ".delta", f + ".delta must be finite");
  }
  for (std::size_t i = 0; i < s.control_points.size(); ++i) {
    const ControlPoint& c = s.control_points[i];
    const std::string f = "control_points[" + std::to_string(i) + "]";
    if (c.link < 0 || c.link >= static_cast<int>(robot.links().size())) throw InvalidInput(f + ".link", f + " is on no link of the robot");
    if (!c.point.allFinite()) throw InvalidInput(f + ".point", f + ".point must be finite");
  }
}

}  // namespace distlab::cbf
