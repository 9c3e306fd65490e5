#pragma once
// A <mesh> collision element as a convex shape: the hull of its scaled vertices.
#include <string>

#include "distlab/geometry/polytope.hpp"
#include "distlab/robot/robot.hpp"

namespace distlab::robot {

// Reads `filename` (resolved by resolve_mesh_path, read by options.read_mesh or load_mesh), scales
// it and returns its convex hull. An open surface (an edge of one face once positions are welded)
// is refused with options.require_closed_meshes, else described in `warning`. Throws
// InvalidInput(field) naming the defect: a missing or unreadable file, an unresolved package, a
// flat mesh, a hull over options.limits.mesh_hull_rows facets.
Polytope mesh_hull(const std::string& filename, const Vec3& scale, const UrdfOptions& options, const std::string& field,
                   std::string& warning);

}  // namespace distlab::robot
