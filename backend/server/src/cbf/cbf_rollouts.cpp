// CBF rollouts kept by the service: the store, their status, frames and the robot description.
#include "distlab/server/cbf_rollouts.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <type_traits>
#include <variant>

#include "cbf_fields.hpp"
#include "distlab/server/cbf_json.hpp"
#include "distlab/server/json_fields.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

// A shape in the request schema of gap_json (SHAPE without pose).
json shape_json(const Shape& shape) {
  return std::visit(
      [](const auto& s) -> json {
        using T = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<T, Box>) return {{"type", "box"}, {"size", vec_json(s.size)}};
        else if constexpr (std::is_same_v<T, Sphere>) return {{"type", "sphere"}, {"radius", s.radius}};
        else if constexpr (std::is_same_v<T, Cylinder>)
          return {{"type", "cylinder"}, {"radius", s.radius}, {"height", s.height}};
        else if constexpr (std::is_same_v<T, Capsule>)
          return {{"type", "capsule"}, {"radius", s.radius}, {"height", s.height}};
        else {
          json A = json::array();
          for (Eigen::Index i = 0; i < s.A.rows(); ++i) A.push_back({s.A(i, 0), s.A(i, 1), s.A(i, 2)});
          return {{"type", "polytope"}, {"A", A}, {"b", vec_json(s.b)}};
        }
      },
      shape);
}

}  // namespace

const char* rollout_state_word(Lifecycle state) { return state == Lifecycle::succeeded ? "finished" : to_string(state); }

const char* CbfRollout::fields_state_word() const {
  if (!ended(fields_state)) return "preparing";
  if (fields_state != Lifecycle::succeeded) return "failed";
  return fields_released ? "released" : "ready";
}

std::size_t CbfRollout::steps_done() const {
  std::lock_guard lock(mutex);
  return steps_locked().size();
}

json CbfRollout::status_json() const {
  json pair_list = json::array();
  for (const cbf::PairInfo& p : pairs)
    pair_list.push_back({{"name", p.name}, {"a", p.a}, {"b", p.b}, {"self", p.self}});
  json j = {{"id", id},
            {"scenario", scenario_name},
            {"metric", cbf::to_string(metric)},
            {"robot", scenario.robot_name},
            {"dt", scenario.dt},
            {"steps_total", steps_total},
            {"pairs", pair_list},
            {"margins", {{"obstacle", scenario.margins(metric).obstacle}, {"self", scenario.margins(metric).self}}},
            {"obstacles", scenario_json.value("obstacles", json::array())},
            {"target", pose_json(scenario.target)},
            {"stream", {{"batch_steps", stream.batch_steps}, {"pairs", stream.pairs}, {"poses", stream.poses}}}};
  if (!fields.empty()) {
    json list = json::array();
    for (const CbfRolloutField& f : fields) list.push_back({{"name", f.name}, {"delta", f.delta}, {"pose", pose_json(f.pose)}});
    j["kelvin"] = {{"control_points", encode_control_points(control_points)}, {"fields", std::move(list)}};
  }
  std::lock_guard lock(mutex);
  if (!fields.empty()) j["kelvin"]["state"] = fields_state_word();
  j["state"] = rollout_state_word(state);
  j["steps_done"] = steps_locked().size();
  if (record) {
    j["summary"] = {{"reached", record->reached},
                    {"final_task_error", record->final_task_error},
                    {"min_distance", finite_or_null(record->min_clearance)},
                    {"infeasible_steps", record->infeasible_steps.size()},
                    {"cancelled", state == Lifecycle::cancelled}};
  }
  return j;
}

json cbf_frames_json(const CbfRollout& r, std::size_t first, std::size_t count) {
  const cbf::Robot& robot = *r.scenario.robot;
  json frames = json::array();
  std::size_t done;
  {
    std::lock_guard lock(r.mutex);
    const std::vector<cbf::StepRecord>& steps = r.steps_locked();
    done = steps.size();
    const std::size_t end = first >= done ? first : first + std::min(count, done - first);
    for (std::size_t i = first; i < end; ++i) {
      const cbf::StepRecord& s = steps[i];
      json f = {{"i", i},
                {"t", s.t},
                {"q", vec_json(s.q)},
                {"u", vec_json(s.u)},
                {"task_error", s.task_error},
                {"min_distance", finite_or_null(s.min_clearance)},
                {"relaxed", s.relaxed},
                {"held", s.held},
                {"slack", s.slack}};
      if (r.stream.pairs && !s.pairs.empty()) {
        json d = json::array(), c = json::array(), a = json::array(), b = json::array();
        for (const cbf::PairSample& p : s.pairs) {
          d.push_back(p.distance);
          c.push_back(finite_or_null(p.clearance));
          a.push_back(vec_json(p.witness_a));
          b.push_back(vec_json(p.witness_b));
        }
        f["distance"] = std::move(d);
        f["clearance"] = std::move(c);
        f["witness_a"] = std::move(a);
        f["witness_b"] = std::move(b);
      }
      if (r.stream.poses) {
        const cbf::Kinematics k = robot.forward(s.q);
        json poses = json::array();
        for (int p = 0; p < static_cast<int>(robot.primitives().size()); ++p) {
          const Pose w = robot.primitive_pose(k, p);
          poses.push_back({w.position.x(), w.position.y(), w.position.z(), w.rotation.w(), w.rotation.x(),
                           w.rotation.y(), w.rotation.z()});
        }
        f["poses"] = std::move(poses);
      }
      if (!s.field_contacts.empty()) {
        json kelvin = json::array();
        for (std::size_t k = 0; k < s.field_contacts.size(); ++k) kelvin.push_back(encode_field_step(s, k, r.control_points.size()));
        f["kelvin"] = std::move(kelvin);
      }
      frames.push_back(std::move(f));
    }
  }
  return {{"type", "cbf_frames"}, {"rollout", r.id}, {"first", first}, {"count", frames.size()}, {"steps_done", done}, {"steps_total", r.steps_total}, {"frames", std::move(frames)}};
}

json cbf_robot_json(const cbf::Robot& robot) {
  json joints = json::array();
  for (const cbf::RobotJoint& jt : robot.joints()) {
    Pose origin;
    origin.position = jt.origin_t;
    origin.rotation = Quat(jt.origin_R);
    const char* type = jt.type == robot::JointType::revolute    ? "revolute"
                       : jt.type == robot::JointType::prismatic ? "prismatic"
                                                                : "fixed";
    joints.push_back({{"name", jt.name}, {"parent", jt.parent}, {"child", jt.child}, {"q", jt.q}, {"type", type}, {"multiplier", jt.multiplier}, {"offset", jt.offset}, {"origin", pose_json(origin)}, {"axis", vec_json(jt.axis)}});
  }
  json prims = json::array();
  for (const cbf::LinkPrimitive& p : robot.primitives())
    prims.push_back({{"name", p.name}, {"link", p.link}, {"shape", shape_json(p.shape)}, {"pose", pose_json(p.pose)}});
  json self = json::array();
  for (const auto& [i, j] : robot.self_pairs()) self.push_back({i, j});
  return {{"name", robot.name()},
          {"dof", robot.dof()},
          {"convention",
           "URDF: joints in evaluation order (parents first); child frame = parent frame · origin · "
           "Rot(axis, θ) (revolute) or Trans(axis θ) (prismatic), θ = multiplier · q[q] + offset (q = -1: "
           "fixed), the base link is the world; a primitive's world pose is "
           "frame[link] · pose; quaternions are [w, x, y, z]"},
          {"links", robot.links()},
          {"joints", joints},
          {"joint_names", robot.joint_names()},
          {"q_min", vec_json(robot.q_min())},
          {"q_max", vec_json(robot.q_max())},
          {"velocity_max", vec_json(robot.velocity_max())},
          {"end_effector", {{"link", robot.ee_link()}}},
          {"primitives", prims},
          {"self_pairs", self}};
}

void CbfRolloutStore::add(const std::shared_ptr<CbfRollout>& r,
                          const std::function<bool(const std::string&)>& alive) {
  std::lock_guard lock(mutex_);
  auto state_of = [](const CbfRollout& x) {
    std::lock_guard l(x.mutex);
    return x.state;
  };
  rollouts_.erase(std::remove_if(rollouts_.begin(), rollouts_.end(),
                                 [&](const auto& x) { return !alive(x->session) && ended(state_of(*x)); }),
                  rollouts_.end());
  rollouts_.push_back(r);
  // Oldest ended rollouts go first; running ones stay (the job limits bound them).
  auto trim = [&](const std::function<bool(const CbfRollout&)>& in_scope, std::size_t keep) {
    std::size_t n = static_cast<std::size_t>(
        std::count_if(rollouts_.begin(), rollouts_.end(), [&](const auto& x) { return in_scope(*x); }));
    for (auto it = rollouts_.begin(); n > keep && it != rollouts_.end();) {
      if (in_scope(**it) && ended(state_of(**it))) {
        it = rollouts_.erase(it);
        --n;
      } else {
        ++it;
      }
    }
  };
  trim([&](const CbfRollout& x) { return x.session == r->session; }, limits_.cbf_rollouts_kept_per_session);
  trim([](const CbfRollout&) { return true; }, limits_.cbf_rollouts_kept_total);
}

void CbfRolloutStore::fields_ready(const std::shared_ptr<CbfRollout>& r) {
  std::lock_guard lock(mutex_);
  with_fields_.erase(std::remove_if(with_fields_.begin(), with_fields_.end(), [](const auto& w) { return w.expired(); }), with_fields_.end());
  with_fields_.push_back(r);
  while (with_fields_.size() > std::max<std::size_t>(1, limits_.cbf_fields_kept_total)) {
    if (auto old = with_fields_.front().lock()) {
      std::lock_guard l(old->mutex);
      for (CbfRolloutField& f : old->fields) f.field.reset();
      old->fields_released = true;
    }
    with_fields_.erase(with_fields_.begin());
  }
}

std::shared_ptr<CbfRollout> CbfRolloutStore::find(const std::string& session, const std::string& id) const {
  std::lock_guard lock(mutex_);
  for (const auto& r : rollouts_)
    if (r->id == id && r->session == session) return r;
  return nullptr;
}

std::vector<std::shared_ptr<CbfRollout>> CbfRolloutStore::list(const std::string& session) const {
  std::lock_guard lock(mutex_);
  std::vector<std::shared_ptr<CbfRollout>> out;
  for (const auto& r : rollouts_)
    if (r->session == session) out.push_back(r);
  return out;
}

}  // namespace distlab::server
