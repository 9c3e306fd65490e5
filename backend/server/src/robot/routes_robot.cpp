// Robot endpoints, one line of the table each: the built-in robots, and the distances of a robot
// (built-in or URDF with uploaded meshes) to obstacles and itself, with their Jacobians in joint
// space, for a batch of configurations.
#include <filesystem>
#include <mutex>

#include "distlab/robot/robot.hpp"
#include "distlab/server/deadline.hpp"
#include "robot_module.hpp"
#include "robot_run.hpp"

namespace distlab::server {

void RobotModule::register_routes() {
  using M = RobotModule;
  // A row per route, as a table.
  // clang-format off
  add_routes<M>(router_, *this, config_.limits, {
    {"GET", "/api/robot/robots", Work::light, {}, codec(decode_nothing, &M::robots, encode_robot_list)},
    {"POST", "/api/robot/distances", Work::heavy, {"max_body_bytes", "max_urdf_bytes", "max_robot_configurations", "max_robot_pair_evaluations", "max_robot_obstacles", "max_gap_iterations", "max_request_seconds"},
     codec(decode_robot_distances, &M::distances, encode_robot_distances)},
  });
  // clang-format on
}

std::string RobotModule::robots_dir() const { return (std::filesystem::path(config_.assets_dir) / "robots").string(); }

// Parses each built-in URDF once (Robot::load caches them).
RobotList RobotModule::robots(const Nothing& /*input*/, const Caller& /*caller*/) {
  RobotList list;
  const std::string dir = robots_dir();
  for (const std::string& name : builtin_robot_names(dir)) list.robots.emplace_back(name, builtin_robot(name, dir, "robot"));
  return list;
}

RobotDistances RobotModule::distances(const RobotDistancesRequest& request, const Caller& caller) {
  const Limits& lim = config_.limits;
  const Deadline deadline(lim.max_request_seconds);
  std::shared_ptr<const robot::Robot> robot = request_robot(request, caller);
  const std::vector<double> q = robot_configurations(request.q, robot->dof());
  const int n = static_cast<int>(request.q.rows.size());
  RobotDistances out;
  out.robot_name = request.urdf ? robot->name() : request.builtin;
  out.gradient = request.params.params.gradient;
  // Throws InvalidInput naming "params.*", "obstacles[i]..." or "pairs.allow[i]" / "pairs.deny[i]".
  const auto check = [&] { deadline.check("send fewer or simpler collision elements and obstacles"); };
  out.model = std::make_shared<const robot::DistanceModel>(std::move(robot), request.obstacles, request.metric, request.params.params,
                                                           request.pairs, nullptr, check);
  const std::size_t evaluations = static_cast<std::size_t>(n) * out.model->pairs().size();
  if (evaluations > lim.max_robot_pair_evaluations)
    throw ApiError(413, "too_many_evaluations",
                   std::to_string(n) + " configurations × " + std::to_string(out.model->pairs().size()) + " pairs is above this server's " +
                       std::to_string(lim.max_robot_pair_evaluations) + " per request; send fewer configurations or pairs",
                   "q");
  out.batch = run_robot_distances(*out.model, q, n, request.params.validate, request.urdf ? "robot.urdf" : "robot",
                                  [&] { deadline.check("send fewer configurations per request"); });
  return out;
}

std::shared_ptr<const robot::Robot> RobotModule::request_robot(const RobotDistancesRequest& request, const Caller& caller) {
  if (!request.urdf) return builtin_robot(request.builtin, robots_dir(), "robot");
  // Only a URDF with meshes needs the session (its uploads), looked up before the URDF is parsed.
  return urdf_robot(*request.urdf, request.urdf->meshes.empty() ? std::map<std::string, std::shared_ptr<const Upload>>{}
                                                                : mesh_uploads(request.urdf->meshes, caller));
}

std::map<std::string, std::shared_ptr<const Upload>> RobotModule::mesh_uploads(const std::map<std::string, std::string>& meshes,
                                                                               const Caller& caller) {
  std::map<std::string, std::shared_ptr<const Upload>> out;
  for (const auto& [filename, id] : meshes) {
    const std::string field = robot_mesh_field(filename);
    std::shared_ptr<Session> session;
    try {
      session = require_session(caller);
    } catch (const ApiError& e) {
      throw ApiError(e.status(), e.code(), std::string(e.what()) + " (robot.meshes names uploads of a session)", field);
    }
    std::lock_guard lock(session->mutex);
    const auto& uploads = session->state<SessionUploads>().uploads;
    const auto it = uploads.find(id);
    if (it == uploads.end()) throw ApiError(404, "unknown_upload", "no such upload in this session", field);
    out[filename] = it->second;
  }
  return out;
}

}  // namespace distlab::server
