#pragma once
// The GAP feature as a module of the service: distances and level sets (routes_gap.cpp), with the
// JSON codec of gap_json.hpp.
#include <string>

#include "distlab/server/module.hpp"

namespace distlab::server {

class GapModule final : public Module {
 public:
  using Module::Module;
  std::string name() const override { return "gap"; }
  void register_routes() override;
};

}  // namespace distlab::server
