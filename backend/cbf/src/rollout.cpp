#include "distlab/cbf/rollout.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

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
    if (row < np) {
      const PairSample& s = out.pairs[row];
      a.name = pairs[row].name;
      a.distance = s.distance;
      a.margin = pairs[row].self ? margin.self : margin.obstacle;
      a.clearance = s.clearance;
      a.converged_distance = s.converged_distance;
    } else {
      const int i = (row - np) % robot.dof();
      const bool lower = row - np < robot.dof();
      a.pair = false;
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

RolloutRecord rollout(const Scenario& scenario, Metric metric, const RolloutOptions& options) {
  const auto w0 = std::chrono::steady_clock::now();
  CbfController controller(scenario, metric);
  RolloutRecord rec;
  rec.metric = metric;
  rec.dt = scenario.dt;
  rec.pairs = controller.pairs();
  rec.gap_mode = scenario.gap_mode;
  rec.min_clearance = std::numeric_limits<double>::infinity();
  const int n = scenario.steps();
  rec.steps.reserve(static_cast<std::size_t>(n));
  VecQ q = scenario.q0;
  for (int i = 0; i < n; ++i) {
    if (options.cancel && options.cancel->load(std::memory_order_relaxed)) {
      rec.cancelled = true;
      break;
    }
    StepOutput out = controller.step(q, options.audit_clearance);
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
    if (s.relaxed || s.held) rec.infeasible_steps.push_back(i);
    if (options.audit_clearance) rec.min_clearance = std::min(rec.min_clearance, s.min_clearance);
    rec.timing.kinematics += s.timing.kinematics;
    rec.timing.distance += s.timing.distance;
    rec.timing.qp += s.timing.qp;
    rec.timing.step += s.timing.step;
    rec.timing.audit += s.timing.audit;
    q += out.u * scenario.dt;
    rec.steps.push_back(std::move(s));
    if (options.progress && !options.progress(i, rec.steps.back())) {
      rec.cancelled = true;
      break;
    }
  }
  const double count = std::max<std::size_t>(1, rec.steps.size());
  rec.timing.kinematics /= count;
  rec.timing.distance /= count;
  rec.timing.qp /= count;
  rec.timing.step /= count;
  rec.timing.audit /= count;
  if (!options.audit_clearance) rec.min_clearance = std::numeric_limits<double>::quiet_NaN();
  rec.q_final = q;
  const Robot& robot = controller.robot();
  rec.final_task_error = task_function(robot.forward(q), robot, scenario.target).r.norm();
  rec.reached = !rec.cancelled && rec.final_task_error < scenario.goal_tolerance;
  rec.final_state = final_state(controller, q);
  rec.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
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
