#pragma once
// Procedural closed meshes: test objects and the project's assets (all outward-oriented, metres).
#include "distlab/mesh/surface.hpp"

namespace distlab::mesh {

// Axis-aligned box centred at the origin with the given edge lengths (12 triangles).
SurfaceMesh box(const Vec3& size);

// Icosphere: the icosahedron subdivided `level` times, vertices projected onto the sphere.
SurfaceMesh icosphere(double radius, int level, const Vec3& centre = Vec3::Zero());

// Concatenation of disjoint meshes (indices shifted).
SurfaceMesh merge(const SurfaceMesh& a, const SurfaceMesh& b);

}  // namespace distlab::mesh
