#pragma once
// Robots as a library over HTTP (issue 32): every distance of a robot and its gradient in joint
// space for one or many configurations (routes_robot.cpp), with the codec of distlab/server/robot_json.hpp.
#include <map>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "distlab/server/module.hpp"
#include "distlab/server/robot_json.hpp"
#include "distlab/server/uploads.hpp"

namespace distlab::server {

class RobotModule final : public Module {
 public:
  using Module::Module;
  std::string name() const override { return "robot"; }
  void register_routes() override;

  RobotList robots(const Nothing& input, const Caller& caller);
  RobotDistances distances(const RobotDistancesRequest& request, const Caller& caller);

 private:
  std::string robots_dir() const;  // the built-in robots, NAME.urdf
  std::shared_ptr<const robot::Robot> request_robot(const RobotDistancesRequest& request, const Caller& caller);
  // The uploads a URDF's meshes name, from the caller's session: 401 without one, 404
  // unknown_upload, each naming its entry.
  std::map<std::string, std::shared_ptr<const Upload>> mesh_uploads(const std::map<std::string, std::string>& meshes,
                                                                    const Caller& caller);
};

}  // namespace distlab::server
