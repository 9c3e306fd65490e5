#pragma once
// Procedural closed meshes: test objects and the project's assets (all outward-oriented, metres).
#include "distlab/mesh/surface.hpp"

namespace distlab::mesh {

// Axis-aligned box centred at the origin with the given edge lengths (12 triangles).
SurfaceMesh box(const Vec3& size);

// Icosphere: the icosahedron subdivided `level` times, vertices projected onto the sphere.
SurfaceMesh icosphere(double radius, int level, const Vec3& centre = Vec3::Zero());

// A scan-like torus (radii 1 and 0.3, n × n grid: 2 n² faces) whose tube radius carries bumps of
// 5 % and a ripple finer than the grid (a scan's noise): big inputs of tests and benchmarks.
SurfaceMesh rippled_torus(int n);

// Concatenation of disjoint meshes (indices shifted).
SurfaceMesh merge(const SurfaceMesh& a, const SurfaceMesh& b);

}  // namespace distlab::mesh
