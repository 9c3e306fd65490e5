#pragma once
// A decoded robot distances request run (routes_robot.cpp): its robot resolved (a built-in one, or
// a URDF with meshes from the caller's uploads), q checked against the robot's dof, and every
// configuration's distances in chunks.
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "distlab/robot/distances.hpp"
#include "distlab/robot/robot.hpp"
#include "distlab/server/robot_json.hpp"
#include "distlab/server/uploads.hpp"

namespace distlab::server {

// The built-in robots' names: NAME.urdf in robots_dir, sorted.
std::vector<std::string> builtin_robot_names(const std::string& robots_dir);

// The built-in robot NAME (robots_dir/NAME.urdf, parsed once), or InvalidInput naming `field`.
std::shared_ptr<const robot::Robot> builtin_robot(const std::string& name, const std::string& robots_dir, const std::string& field);

// The URDF with its meshes, `meshes` (filename → the upload its entry names); errors name
// "robot.urdf", "robot.meshes" or the entry whose mesh has a defect or is not in the URDF.
std::shared_ptr<const robot::Robot> urdf_robot(const RobotUrdf& urdf, const std::map<std::string, std::shared_ptr<const Upload>>& meshes);

// q against the robot's dof: its n rows of dof numbers, row-major; InvalidInput naming "q" or "q[i]".
std::vector<double> robot_configurations(const RobotQ& q, int dof);

// Checks Property 2 of every GAP body in a pair (validate_robot_bodies, errors naming
// `robot_field`) when `validate`, then the n configurations of q (n × dof) in chunks; `checkpoint` runs between
// chunks (the request's time limit). Configurations continue each other's GAP solutions (a
// trajectory).
robot::DistanceBatch run_robot_distances(const robot::DistanceModel& model, const std::vector<double>& q, int n, bool validate,
                                         const std::string& robot_field, const std::function<void()>& checkpoint);

}  // namespace distlab::server
