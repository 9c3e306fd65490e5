#pragma once
// The Panda of the CBF tests: assets/robots/panda.urdf, the DH frame i as a link index, and the
// narrow corridor. (The robot module's own helpers: tests/robot/robot_test_util.hpp.)
#include <memory>
#include <string>

#include "distlab/cbf/scenario.hpp"

namespace distlab::cbf::test {

inline std::shared_ptr<const Robot> panda() {
  return Robot::load(std::string(DISTLAB_SOURCE_DIR) + "/assets/robots/panda.urdf");
}
inline int dh_frame(const Robot& robot, int i) { return robot.link_index("panda_link" + std::to_string(i)); }
inline Scenario narrow() { return corridor_narrow_scenario(panda()); }

}  // namespace distlab::cbf::test
