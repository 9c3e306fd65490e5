#pragma once
// Robots as a library over HTTP (issue 32): every distance of a robot and its gradient in joint
// space for one or many configurations (routes_robot.cpp), with the codec of distlab/server/robot_json.hpp.
#include <string>

#include <nlohmann/json.hpp>

#include "distlab/server/module.hpp"

namespace distlab::server {

class RobotModule final : public Module {
 public:
  using Module::Module;
  std::string name() const override { return "robot"; }
  void register_routes() override;
  // The robot library's description limits (robot.hpp), enforced on every URDF.
  void add_limits(nlohmann::json& limits) const override;
};

}  // namespace distlab::server
