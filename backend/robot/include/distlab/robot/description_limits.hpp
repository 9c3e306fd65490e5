#pragma once
// Limits of a robot description, apart from the rest of robot.hpp so that the server's limits
// table (server/config.hpp) takes its defaults from here without the robot's headers.
#include <cstddef>

namespace distlab::robot {

// Limits of a description, the library's defaults (the CLI's and the Python bindings'); a caller
// that serves untrusted descriptions sets its own through UrdfOptions::limits (the server: from
// its limits table, GET /api/limits max_urdf_bytes, max_robot_links, ...).
inline constexpr std::size_t kMaxUrdfBytes = std::size_t{1} << 20;
inline constexpr int kMaxLinks = 256;
inline constexpr int kMaxJoints = 256;
inline constexpr int kMaxCollisionElements = 512;
inline constexpr int kMaxMeshHullRows = 16384;  // facets of one mesh's hull
inline constexpr std::size_t kMaxMeshVertices = 2'000'000;

struct DescriptionLimits {
  std::size_t urdf_bytes = kMaxUrdfBytes;  // of the text
  int links = kMaxLinks;
  int joints = kMaxJoints;
  int collision_elements = kMaxCollisionElements;  // of the whole robot
  int mesh_hull_rows = kMaxMeshHullRows;           // facets of one mesh's hull
  std::size_t mesh_vertices = kMaxMeshVertices;    // of one mesh file
};

}  // namespace distlab::robot
