#pragma once
// Rigid pose of a shape frame in the world: x_world = R x_local + t.
#include "distlab/geometry/types.hpp"

namespace distlab {

struct Pose {
  Vec3 position = Vec3::Zero();
  Quat rotation = Quat::Identity();  // unit quaternion

  Mat3 R() const { return rotation.toRotationMatrix(); }
  Vec3 to_world(const Vec3& local) const { return rotation * local + position; }
  Vec3 to_local(const Vec3& world) const { return rotation.conjugate() * (world - position); }
  Vec3 dir_to_world(const Vec3& local) const { return rotation * local; }
  Vec3 dir_to_local(const Vec3& world) const { return rotation.conjugate() * world; }
};

}  // namespace distlab
