#pragma once
// The GAP feature as a module of the service: distances and level sets (routes_gap.cpp), with the
// codec of gap_codec.hpp.
#include <string>

#include "distlab/server/module.hpp"
#include "gap_codec.hpp"

namespace distlab::server {

class GapModule final : public Module {
 public:
  using Module::Module;
  std::string name() const override { return "gap"; }
  void register_routes() override;

  GapDistanceResults distance(const GapDistanceRequest& request, const Caller& caller);
  GapLevelsetsResult levelsets(const GapLevelsetsRequest& request, const Caller& caller);
};

}  // namespace distlab::server
