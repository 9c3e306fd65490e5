#pragma once
// Scalar fields sampled on regular grids and planes, and their iso-surfaces (marching tetrahedra).
#include <array>
#include <functional>
#include <stdexcept>
#include <vector>

#include "distlab/geometry/progress.hpp"
#include "distlab/geometry/types.hpp"
#include "distlab/mesh/surface.hpp"

namespace distlab::levelset {

// Values at the nodes origin + (i, j, k) * spacing, i fastest.
struct Grid {
  Vec3 origin = Vec3::Zero();
  Vec3 spacing = Vec3::Ones();
  std::array<int, 3> n{0, 0, 0};  // nodes per axis (>= 2 each)
  std::vector<double> values;

  std::size_t index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(n[0]) * (static_cast<std::size_t>(j) + static_cast<std::size_t>(n[1]) * static_cast<std::size_t>(k));
  }
  Vec3 node(int i, int j, int k) const {
    return origin + Vec3(i * spacing.x(), j * spacing.y(), k * spacing.z());
  }
};

// The project's one progress and cancellation (geometry/progress.hpp).
using distlab::Cancelled;
using distlab::Progress;

using ScalarField = std::function<double(const Vec3&)>;

// Several fields evaluated at once per point (cheaper when they share work).
using MultiField = std::function<void(const Vec3&, double* out)>;

// Samples `count` fields on the nodes of [lo, hi] with n nodes per axis, on `threads` threads
// (0: all cores). Throws InvalidInput("grid") for n < 2 or an empty box. progress("sample",
// fraction) is called before each row of nodes, from the sampling threads (its report must be
// thread-safe); what it throws (Cancelled, a request's time limit) stops the sampling.
std::vector<Grid> sample_grid(const MultiField& f, int count, const Vec3& lo, const Vec3& hi,
                              const std::array<int, 3>& n, unsigned threads = 0, const Progress& progress = {});

// The level set {value = level}, triangulated by marching tetrahedra (six tetrahedra per cell, Kuhn split, so neighbouring
// cells agree). Triangles are oriented with their normals towards increasing value; vertices on
// shared edges are shared. Surfaces cut by the grid box are open there.
mesh::SurfaceMesh marching_tetrahedra(const Grid& grid, double level);

// A rectangle of the plane through `centre` spanned by unit u, v: nodes centre + (s - ½)·size_u·u
// + (t - ½)·size_v·v for s, t in [0, 1] on an nu × nv lattice (u fastest).
struct PlaneFrame {
  Vec3 centre = Vec3::Zero();
  Vec3 u = Vec3::UnitX();
  Vec3 v = Vec3::UnitY();
  double size_u = 1, size_v = 1;
  int nu = 2, nv = 2;
};
// Builds u, v from a normal (any orthonormal pair perpendicular to it, deterministic).
PlaneFrame plane_from_normal(const Vec3& centre, const Vec3& normal, double size_u, double size_v,
                             int nu, int nv);
// Samples `count` fields on the plane's lattice; result[f][s + nu * t].
std::vector<std::vector<double>> sample_plane(const MultiField& f, int count, const PlaneFrame& plane,
                                              unsigned threads = 0);

}  // namespace distlab::levelset
