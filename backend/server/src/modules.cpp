// Wiring: the one place that names every feature module. A new feature adds its line here.
#include "distlab/server/modules.hpp"

#include "cbf/cbf_module.hpp"
#include "gap/gap_module.hpp"
#include "kelvin/kelvin_module.hpp"
#include "robot/robot_module.hpp"
#include "scene/scene_module.hpp"

namespace distlab::server {

void add_standard_modules(Service& service) {
  service.add<GapModule>();
  service.add<KelvinModule>();
  service.add<CbfModule>();
  service.add<RobotModule>();
  service.add<SceneModule>();
}

}  // namespace distlab::server
