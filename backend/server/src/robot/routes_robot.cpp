// Robot endpoints, one line of the table each: the built-in robots, and the distances of a robot
// (built-in or URDF with uploaded meshes) to obstacles and itself, with their Jacobians in joint
// space, for a batch of configurations.
#include <filesystem>
#include <mutex>

#include "distlab/robot/robot.hpp"
#include "distlab/server/deadline.hpp"
#include "distlab/server/robot_json.hpp"
#include "distlab/server/uploads.hpp"
#include "robot_module.hpp"

namespace distlab::server {

using json = nlohmann::json;

void RobotModule::add_limits(json& limits) const {
  limits["max_urdf_bytes"] = robot::kMaxUrdfBytes;
  limits["max_robot_links"] = robot::kMaxLinks;
  limits["max_robot_joints"] = robot::kMaxJoints;
  limits["max_robot_collision_elements"] = robot::kMaxCollisionElements;
  limits["max_robot_mesh_hull_facets"] = robot::kMaxMeshHullRows;
  limits["max_robot_mesh_vertices"] = robot::kMaxMeshVertices;
}

void RobotModule::register_routes() {
  const std::string robots_dir = (std::filesystem::path(config_.assets_dir) / "robots").string();

  // Parses each built-in URDF once (Robot::load caches them).
  router_.add({"GET", "/api/robot/robots", [robots_dir](Request&) { return json_response(200, robots_json(robots_dir)); }});

  Route distances{"POST", "/api/robot/distances", [this, robots_dir](Request& req) {
                    RobotSources sources;
                    sources.robots_dir = robots_dir;
                    // Only a URDF with meshes needs the session (its uploads).
                    sources.upload = [this, &req](const std::string& id, const std::string& field) {
                      std::shared_ptr<Session> session;
                      try {
                        session = require_session(req);
                      } catch (const ApiError& e) {
                        throw ApiError(e.status(), e.code(), std::string(e.what()) + " (robot.meshes names uploads of a session)", field);
                      }
                      std::lock_guard lock(session->mutex);
                      const auto& uploads = session->state<SessionUploads>().uploads;
                      const auto it = uploads.find(id);
                      if (it == uploads.end()) throw ApiError(404, "unknown_upload", "no such upload in this session", field);
                      return it->second;
                    };
                    const Limits& lim = config_.limits;
                    const Deadline deadline(lim.max_request_seconds);
                    const RobotDistancesRequest request = parse_robot_distances(parse_body(req), sources, lim);
                    const robot::DistanceBatch batch = run_robot_distances(request, [&] { deadline.check("send fewer configurations per request"); });
                    return json_response(200, encode_robot_distances(request, batch));
                  }};
  distances.heavy = true;
  distances.bounds = {"max_body_bytes", "max_urdf_bytes", "max_robot_configurations", "max_robot_pair_evaluations", "max_robot_obstacles",
                      "max_gap_iterations", "max_request_seconds"};
  router_.add(std::move(distances));
}

}  // namespace distlab::server
