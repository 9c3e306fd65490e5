#pragma once
// The robot feature's JSON codec, shared by POST /api/robot/distances (routes_robot.cpp) and the
// Python bindings (distlab.robot): the obstacles, the pair selection, the metric and the
// Property 2 check of a DistanceModel's bodies are read and checked here once, so both name the
// same fields ("obstacles[1].size[0]", "pairs.allow[0]") and follow the same rules.
//
// Request:  {"robot": NAME | {"urdf": TEXT, "meshes"?: {FILENAME: UPLOAD_ID}},
//            "q": [dof numbers] | [[dof numbers], ...],
//            "obstacles"?: [SHAPE + optional "name"],       (SHAPE as gap_json's, world pose)
//            "metric"?: "gap" | "euclidean",                  (default gap)
//            "pairs"?: "obstacles" | "self" | "both" | {"obstacles", "self", "allow", "deny"},
//            "params"?: PARAMS, "comment"?}                   (PARAMS as gap_json's)
//           NAME: assets/robots/NAME.urdf. FILENAME: a <mesh filename> exactly as the URDF writes
//           it; UPLOAD_ID: an upload of this session (POST /api/kelvin/uploads, unit m: the URDF's
//           scale then applies), already parsed in the isolated child. allow / deny: [[LINK, LINK],
//           ...] self pairs added / removed (they need "self": true).
// Response: {"robot", "dof", "joint_names", "metric", "n", "warnings" (the robot's: a mesh that is
//            not closed, whose vertices' hull is used), "pairs": [{"name", "link", "element",
//            "self", "obstacle" | "other": {"link", "element"}}], "distance": (N, P),
//            "jacobian": (N, P, dof) (unless params.gradient is false), "witness_robot",
//            "witness_obstacle": (N, P, 3), "overlap", "converged", "iterations": (N, P)}:
//           always N-leading arrays, also for one configuration.
// Errors:   InvalidInput / ApiError naming the field: "q[3][2]", "obstacles[1].size",
//           "robot.meshes[\"x.stl\"]", "pairs.allow[0]", "params.tol", ...
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/robot/distances.hpp"
#include "distlab/robot/robot.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/http.hpp"

namespace distlab::server {

// [SHAPE + optional "name"], at most max_robot_obstacles (413 too_many_obstacles), each a GAP
// request shape with its world "pose". A name has 1 to 64 characters; an obstacle without one is
// "obstacle<i>" (i its index, as in the CBF scenarios). Names are distinct, since they name the
// pairs: a repeated one (given, or a default that another obstacle took) is
// InvalidInput("obstacles[i].name"). Other errors name "obstacles[i].<key>".
std::vector<robot::Obstacle> parse_robot_obstacles(const nlohmann::json& j, const Limits& limits = {});

// "obstacles" | "self" | "both" | {"obstacles": bool, "self": bool, "allow": [[LINK, LINK], ...],
// "deny": [...]} (allow / deny edit the self pairs, so they need "self": true); errors name
// "pairs", "pairs.<key>", "pairs.allow[i]", ... (an unknown link: DistanceModel, "pairs.allow[i]").
robot::PairSelection parse_pair_selection(const nlohmann::json& j, const Limits& limits = {});

// "gap" | "euclidean"; InvalidInput("metric") otherwise.
robot::Metric parse_robot_metric(const nlohmann::json& j);

// Property 2 (validate_p2s, cached per shape) of every GAP body in one of the model's pairs, each
// body once, on all cores; `checkpoint` runs before each. A failing obstacle is
// InvalidInput("obstacles[i]"), a failing collision element InvalidInput(robot_field) whose
// message names the element.
void validate_robot_bodies(const robot::DistanceModel& model, const std::string& robot_field,
                           const std::function<void()>& checkpoint = {});

// POST /api/robot/distances, read and checked as far as it can be without the robot: its robot
// as given, q's rows of numbers (finite, |q_i| <= kMaxCoordinate, at most max_robot_configurations
// rows: 413 too_many_configurations), the obstacles, pairs, metric and params. The handler
// resolves the robot (robot_run.hpp) and checks q against its dof.
struct RobotUrdf {
  std::string text;                           // at most max_urdf_bytes
  std::map<std::string, std::string> meshes;  // <mesh filename> → upload id of the caller's session
  robot::DescriptionLimits limits;            // the table's, for the library to check the rest
};
struct RobotQRow {
  std::vector<double> values;
  std::size_t length = 0;  // the row's elements
  std::string not_array;   // the JSON type of a row that is no array ("" for an array)
  // The row's first element that is no finite number in range, reported once its length is
  // checked against the dof (a row of the wrong length names the row, as the robot sees it).
  std::string bad_field, bad_message;
};
struct RobotQ {
  bool several = false;         // [[...], ...] rather than one configuration
  std::vector<RobotQRow> rows;  // none when q is no array or an empty one
};
struct RobotDistancesRequest {
  std::string builtin;            // a built-in robot's name, or "" with urdf
  std::optional<RobotUrdf> urdf;  // {"urdf", "meshes"}
  RobotQ q;
  std::vector<robot::Obstacle> obstacles;
  robot::Metric metric = robot::Metric::gap;
  robot::PairSelection pairs;
  GapRequestParams params;
};
RobotDistancesRequest decode_robot_distances(const Request& request, const Limits& limits);

// "robot.meshes[\"x.stl\"]": the field of a meshes entry (the file name as a JSON string, shortened).
std::string robot_mesh_field(const std::string& filename);

// The answer's content: the model (robot, obstacles, metric, pairs) and every configuration's
// distances.
struct RobotDistances {
  std::shared_ptr<const robot::DistanceModel> model;
  std::string robot_name;  // the built-in's name, or the URDF's <robot name>
  bool gradient = true;    // params.gradient: the answer has "jacobian"
  robot::DistanceBatch batch;
};
// The answer (above). std::runtime_error for a non-finite number, which is never sent.
Response encode_robot_distances(const RobotDistances& result);

// GET /api/robot/robots: the built-in robots by name, sorted; answered {"robots": [{"name", "dof",
// "joint_names", "links", "elements": [{"name", "link"}], "self_pairs"}]}.
struct RobotList {
  std::vector<std::pair<std::string, std::shared_ptr<const robot::Robot>>> robots;
};
Response encode_robot_list(const RobotList& list);

}  // namespace distlab::server
