#pragma once
// Geometric queries on the input surface (x-space): inside test, closest point, deepest point,
// and edge splitting before inversion (also the AABB-tree distance baseline of the benchmark).
#include <memory>

#include "distlab/mesh/surface.hpp"

namespace distlab::kelvin {

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
  // A point far from the surface: the interior grid point with the largest clearance.
  Vec3 deepest_point() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Splits every edge longer than max_length (points stay on the original faces).
mesh::SurfaceMesh split_long_edges(const mesh::SurfaceMesh& surface, double max_length);

}  // namespace distlab::kelvin
