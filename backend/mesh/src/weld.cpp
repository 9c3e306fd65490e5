// Exact-position weld of a user mesh (weld.hpp).
#include "distlab/mesh/weld.hpp"

#include <array>
#include <map>

namespace distlab::mesh {

Welded weld(const SurfaceMesh& user) {
  const auto nv = user.vertices.rows();
  std::vector<char> used(static_cast<std::size_t>(nv), 0);
  for (Eigen::Index f = 0; f < user.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) used[static_cast<std::size_t>(user.faces(f, k))] = 1;
  Welded out;
  out.to_welded.assign(static_cast<std::size_t>(nv), -1);
  // An ordered map on the exact coordinates (+ 0.0 turns −0 into +0): deterministic, and
  // O(n log n) on the at most max_upload_triangles · 3 vertices of an upload.
  std::map<std::array<double, 3>, int> index;
  std::vector<Eigen::Index> first;  // welded vertex -> its first user vertex
  for (Eigen::Index v = 0; v < nv; ++v) {
    if (!used[static_cast<std::size_t>(v)]) continue;
    const std::array<double, 3> key{user.vertices(v, 0) + 0.0, user.vertices(v, 1) + 0.0, user.vertices(v, 2) + 0.0};
    auto [it, inserted] = index.emplace(key, static_cast<int>(first.size()));
    if (inserted) first.push_back(v);
    out.to_welded[static_cast<std::size_t>(v)] = it->second;
  }
  out.surface.vertices.resize(static_cast<Eigen::Index>(first.size()), 3);
  for (std::size_t w = 0; w < first.size(); ++w) out.surface.vertices.row(static_cast<Eigen::Index>(w)) = user.vertices.row(first[w]);
  out.surface.faces.resize(user.faces.rows(), 3);
  for (Eigen::Index f = 0; f < user.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) out.surface.faces(f, k) = out.to_welded[static_cast<std::size_t>(user.faces(f, k))];
  out.surface.polygon_corners = user.polygon_corners;  // the same faces in the same order
  return out;
}

}  // namespace distlab::mesh
