#pragma once
// Geometric queries on the input surface (x-space): inside test, closest point, deepest point
// (also the AABB-tree distance baseline of the benchmark).
#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "distlab/mesh/surface.hpp"

namespace distlab::kelvin {

// The sharp edges (vertex pairs a < b) of a surface: the two faces' normals deviate by more than
// feature_angle degrees (none at 180). Eq. 23 has Mesh_3 protect them; the graded sizing refines
// near them.
std::vector<std::pair<int, int>> sharp_edges(const mesh::SurfaceMesh& s, double feature_angle);

// Vertices the graded sizing (PrepareOptions::grading) adds near sharp edges, per metre of edge
// and per 1/l_x, as an upper bound: the cube, wrench and knife measured 57–72 (kGradedEdgeVerticesTypical), counted 150.
inline constexpr double kGradedEdgeVerticesPerLength = 150;

class SurfaceOracle {
 public:
  explicit SurfaceOracle(const mesh::SurfaceMesh& surface);
  ~SurfaceOracle();
  SurfaceOracle(const SurfaceOracle&) = delete;
  SurfaceOracle& operator=(const SurfaceOracle&) = delete;

  bool inside(const Vec3& x) const;  // strictly inside the closed surface
  double distance(const Vec3& x) const;
  // Closest surface point as a face index and barycentric weights of its three vertices.
  void closest(const Vec3& x, int& face, Vec3& weights) const;
  // A point far from the surface: the interior grid point with the largest clearance. tick(f)
  // is called with the fraction done (f in [0, 1]); it may throw to cancel. On a large surface
  // this is the slow part of loading (points deep inside are near-equidistant to many faces).
  Vec3 deepest_point(const std::function<void(double)>& tick = {}) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace distlab::kelvin
