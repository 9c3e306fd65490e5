#include "distlab/cbf/rollout.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "distlab/geometry/error.hpp"

namespace distlab::cbf {

FinalState final_state(CbfController& controller, const VecQ& q) {
  FinalState f;
  const Robot& robot = controller.robot();
  const Scenario& sc = controller.scenario();
  f.ee_position = robot.forward(q).ee.position;
  f.position_error = (f.ee_position - sc.target.position).norm();
  const StepOutput out = controller.step(q, true);
  const auto& pairs = controller.pairs();
  const int np = static_cast<int>(pairs.size());
  f.min_clearance = std::numeric_limits<double>::infinity();
  for (int p = 0; p < np; ++p)
    if (out.pairs[p].clearance < f.min_clearance) {
      f.min_clearance = out.pairs[p].clearance;
      f.closest_pair = pairs[p].name;
    }
  const Margins& margin = sc.margins(controller.metric());
  for (std::size_t k = 0; k < out.active.size(); ++k) {
    const int row = out.active[k];
    ActiveConstraint a;
    a.multiplier = out.multiplier[k];
    if (row >= np && row < np + controller.field_rows()) {  // a Kelvin field's row
      const FieldBarrier& b = *controller.barrier();
      const std::size_t r = static_cast<std::size_t>(row - np), points = b.points().size();
      const SceneField& field = b.fields()[r / points];
      a.name = b.points()[r % points].name + "/" + field.name;
      a.kind = ActiveConstraint::Kind::field;
      a.distance = out.field_points[r].h;
      a.margin = field.margin;
      a.clearance = std::numeric_limits<double>::quiet_NaN();
    } else if (row < np) {
      const PairSample& s = out.pairs[row];
      a.name = pairs[row].name;
      a.distance = s.distance;
      a.margin = pairs[row].self ? margin.self : margin.obstacle;
      a.clearance = s.clearance;
      a.converged_distance = s.converged_distance;
    } else {
      const int j = row - np - controller.field_rows();
      const int i = j % robot.dof();
      const bool lower = j < robot.dof();
      a.kind = ActiveConstraint::Kind::joint_limit;
      a.name = std::to_string(i + 1);  // appended in steps: GCC 12's -Wrestrict misfires on "q" + …
      a.name.insert(0, 1, 'q');
      a.name.append(lower ? " >= q_min" : " <= q_max");
      a.distance = lower ? q[i] - robot.q_min()[i] : robot.q_max()[i] - q[i];
      a.clearance = std::numeric_limits<double>::quiet_NaN();
    }
    f.active.push_back(std::move(a));
  }
  std::sort(f.active.begin(), f.active.end(),
            [](const ActiveConstraint& x, const ActiveConstraint& y) { return x.multiplier > y.multiplier; });
  return f;
}

void require_safe_start(const Scenario& scenario, const VecQ& q) {
  if (scenario.fields.empty()) return;
  FieldBarrier barrier(scenario.fields, scenario.control_points);
  std::vector<FieldPointSample> samples;
  Eigen::MatrixXd grad;
  barrier.evaluate(*scenario.robot, scenario.robot->forward(q), samples, grad);
  const std::size_t points = scenario.control_points.size();
  for (std::size_t r = 0; r < samples.size(); ++r) {
    const SceneField& f = scenario.fields[r / points];
    const std::string where = "control point \"" + scenario.control_points[r % points].name + "\" starts ";
    if (samples[r].status != kelvin::Status::ok)
      throw InvalidInput("control_points", where + "inside the object of field \"" + f.name + "\" (h is undefined there)");
    if (samples[r].h < f.margin)
      throw InvalidInput("control_points", where + "inside the unsafe set of field \"" + f.name + "\": h = " +
                                               std::to_string(samples[r].h) + " < delta = " + std::to_string(f.margin) +
                                               "; no CBF can hold it there (move q0 or the object)");
  }
}

namespace {

// One step of the loop at q, recorded in rec (q moves on by u·dt); false when a field row could
// not be formed (rec.failure says why).
bool record_step(CbfController& controller, const std::vector<FieldSurface>& surfaces, std::vector<Vec3>& points,
                 const Scenario& scenario, Metric metric, const RolloutOptions& options, int i, VecQ& q, RolloutRecord& rec) {
  StepOutput out;
  try {
    out = controller.step(q, options.audit_clearance);
  } catch (const FieldUndefined& e) {  // the barrier no longer exists here: stop, say why
    rec.failure = e.what();
    rec.failure_step = i;
    return false;
  }
  StepRecord s;
  s.t = i * scenario.dt;
  s.q = q;
  s.u = out.u;
  s.task_error = out.task_error;
  s.min_clearance = out.min_clearance;
  s.relaxed = out.relaxed;
  s.held = out.held;
  s.slack = out.slack;
  s.clipped = out.clipped;
  rec.clipped_steps += out.clipped;
  s.active = out.active;
  s.timing = out.timing;
  for (const PairSample& p : out.pairs) rec.cold_solves += p.cold && metric == Metric::gap;
  if (options.record_pairs) s.pairs = std::move(out.pairs);
  if (const FieldBarrier* b = controller.barrier()) {
    const Kinematics k = controller.robot().forward(q);
    for (std::size_t p = 0; p < points.size(); ++p) points[p] = b->world_point(k, static_cast<int>(p));
    for (const FieldSurface& surface : surfaces) s.field_contacts.push_back(surface.contact(points));
    s.field_points = std::move(out.field_points);
  }
  if (s.relaxed || s.held) rec.infeasible_steps.push_back(i);
  if (options.audit_clearance) rec.min_clearance = std::min(rec.min_clearance, s.min_clearance);
  rec.timing.kinematics += s.timing.kinematics;
  rec.timing.distance += s.timing.distance;
  rec.timing.qp += s.timing.qp;
  rec.timing.step += s.timing.step;
  rec.timing.audit += s.timing.audit;
  rec.timing.field += s.timing.field;
  q += out.u * scenario.dt;
  rec.steps.push_back(std::move(s));
  return true;
}

// The record's summary once the steps are done (or stopped: `complete` false, never reached).
void summarise(CbfController& controller, const Scenario& scenario, const RolloutOptions& options, const VecQ& q, bool complete,
               std::chrono::steady_clock::time_point w0, RolloutRecord& rec) {
  const double count = std::max<std::size_t>(1, rec.steps.size());
  rec.timing.kinematics /= count;
  rec.timing.distance /= count;
  rec.timing.qp /= count;
  rec.timing.step /= count;
  rec.timing.audit /= count;
  rec.timing.field /= count;
  if (!options.audit_clearance) rec.min_clearance = std::numeric_limits<double>::quiet_NaN();
  rec.q_final = q;
  const Robot& robot = controller.robot();
  rec.final_task_error = task_function(robot.forward(q), robot, scenario.target).r.norm();
  rec.reached = complete && rec.failure.empty() && rec.final_task_error < scenario.goal_tolerance;
  if (rec.failure.empty()) rec.final_state = final_state(controller, q);
  rec.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
}

}  // namespace

void rollout(const Scenario& scenario, Metric metric, const RolloutOptions& options, RolloutRecord& rec) {
  const auto w0 = std::chrono::steady_clock::now();
  rec = RolloutRecord{};
  // The cancel is polled while the model's bodies are built too (thousand-facet hulls take seconds).
  CbfController controller(scenario, metric, [&] { options.progress.check(); });
  require_safe_start(scenario, scenario.q0);
  std::vector<FieldSurface> surfaces;
  for (const SceneField& f : scenario.fields) surfaces.emplace_back(f);
  std::vector<Vec3> points(scenario.control_points.size());
  rec.control_points = scenario.control_points;
  for (std::size_t i = 0; i < scenario.fields.size(); ++i) {
    const SceneField& f = scenario.fields[i];
    rec.field_names.push_back(f.name);
    rec.field_margins.push_back(f.margin);
    const MatX3& v = f.field->surface().vertices;
    rec.safety_distances.push_back(surfaces[i].forbidden_offset(f.margin, (v.colwise().maxCoeff() - v.colwise().minCoeff()).norm() / 200));
  }
  rec.metric = metric;
  rec.dt = scenario.dt;
  rec.pairs = controller.pairs();
  rec.gap_mode = scenario.gap_mode;
  rec.min_clearance = std::numeric_limits<double>::infinity();
  const int n = scenario.steps();
  rec.steps.reserve(static_cast<std::size_t>(n));
  VecQ q = scenario.q0;
  try {
    for (int i = 0; i < n; ++i) {
      options.progress.check();
      if (!record_step(controller, surfaces, points, scenario, metric, options, i, q, rec)) break;
      if (options.on_step) options.on_step(i, rec.steps.back());
      options.progress("rollout", (i + 1.0) / n);
    }
  } catch (const Cancelled&) {
    summarise(controller, scenario, options, q, false, w0, rec);
    throw;
  }
  summarise(controller, scenario, options, q, true, w0, rec);
}

RolloutRecord rollout(const Scenario& scenario, Metric metric, const RolloutOptions& options) {
  RolloutRecord rec;
  rollout(scenario, metric, options, rec);
  return rec;
}

Smoothness smoothness(const RolloutRecord& record, int joint, double t_begin, double t_end) {
  Smoothness s;
  for (std::size_t i = 1; i < record.steps.size(); ++i) {
    const StepRecord &a = record.steps[i - 1], &b = record.steps[i];
    if (a.t < t_begin || b.t > t_end) continue;
    const double du = std::abs(b.u[joint] - a.u[joint]);
    s.total_variation += du;
    s.max_rate = std::max(s.max_rate, du / record.dt);
  }
  return s;
}

}  // namespace distlab::cbf
