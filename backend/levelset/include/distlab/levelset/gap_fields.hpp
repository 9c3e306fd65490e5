#pragma once
// The GAP point-to-set functions of one shape (weak e_S, strict E_S of eq. 6) as level sets:
// iso-surfaces on a grid around the shape and both fields sampled on a plane (the paper's Fig. 1,
// in 3D).
#include <optional>
#include <vector>

#include "distlab/gap/distance.hpp"
#include "distlab/levelset/grid.hpp"

namespace distlab::levelset {

struct GapLevelsetOptions {
  std::vector<double> weak_levels;    // iso-values of e_S
  std::vector<double> strict_levels;  // iso-values of E_S
  int resolution = 48;                // grid nodes along the longest box side (>= 4)
  // Box of the grid (world frame). Default: a cube around the shape's posed bounding ball, grown
  // by at least `padding` times its radius and further until the largest level fits inside.
  std::optional<std::pair<Vec3, Vec3>> bounds;
  double padding = 0.75;
  std::optional<PlaneFrame> plane;  // sample e_S and E_S here if set
  unsigned threads = 0;
};

struct IsoSurface {
  bool strict = false;  // E_S (true) or e_S (false)
  double level = 0;
  mesh::SurfaceMesh mesh;
};

struct GapLevelsets {
  Vec3 lo, hi;                                   // the grid box
  std::array<int, 3> n{0, 0, 0};                 // grid nodes per axis
  std::vector<IsoSurface> surfaces;              // weak levels first, then strict, in the given order
  std::vector<double> plane_weak, plane_strict;  // empty without a plane
};

// Throws InvalidInput (fields "levels.*", "grid.*", "plane.*") on bad options. `progress` is
// called as sample_grid calls it, then with "mesh" before each iso-surface; what it throws
// (Cancelled, a request's time limit) stops the work.
GapLevelsets gap_levelsets(const PointToSet& p2s, const GapLevelsetOptions& options, const Progress& progress = {});

}  // namespace distlab::levelset
