#pragma once
// An edge count of the tests' own, independent of mesh/checks.hpp: a surface welded at float32
// (what an STL file carries), faces per edge, fans per vertex, face-connected pieces.
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "distlab/mesh/surface.hpp"

namespace distlab::test {

struct Count {
  long bad_edges = 0;  // edges not in exactly two faces
  long collapsed = 0;  // faces with a corner twice after the weld
  long pinched = 0;    // vertices whose faces form more than one fan
  long components = 0;
};

inline Count count(const mesh::SurfaceMesh& s) {
  std::map<std::array<float, 3>, int> id;
  std::vector<int> to(static_cast<size_t>(s.vertices.rows()));
  for (Eigen::Index v = 0; v < s.vertices.rows(); ++v) {
    const std::array<float, 3> p{static_cast<float>(s.vertices(v, 0)) + 0.0f, static_cast<float>(s.vertices(v, 1)) + 0.0f,
                                 static_cast<float>(s.vertices(v, 2)) + 0.0f};
    to[static_cast<size_t>(v)] = id.emplace(p, static_cast<int>(id.size())).first->second;
  }
  Count c;
  std::map<std::pair<int, int>, std::vector<int>> edges;
  std::vector<std::array<int, 3>> faces;
  for (Eigen::Index f = 0; f < s.faces.rows(); ++f) {
    const std::array<int, 3> t{to[static_cast<size_t>(s.faces(f, 0))], to[static_cast<size_t>(s.faces(f, 1))], to[static_cast<size_t>(s.faces(f, 2))]};
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      ++c.collapsed;
      continue;
    }
    for (int k = 0; k < 3; ++k) edges[std::minmax(t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)])].push_back(static_cast<int>(faces.size()));
    faces.push_back(t);
  }
  for (const auto& [e, fs] : edges) c.bad_edges += fs.size() != 2;
  // Fans: per vertex, its faces joined across edges through it (flood fill).
  std::vector<std::vector<int>> star(id.size());
  for (size_t f = 0; f < faces.size(); ++f)
    for (const int v : faces[f]) star[static_cast<size_t>(v)].push_back(static_cast<int>(f));
  for (size_t v = 0; v < star.size(); ++v) {
    if (star[v].empty()) continue;
    std::set<int> seen{star[v][0]}, todo{star[v][0]};
    while (!todo.empty()) {
      const int f = *todo.begin();
      todo.erase(todo.begin());
      for (const int w : faces[static_cast<size_t>(f)]) {
        if (w == static_cast<int>(v)) continue;
        for (const int g : edges[std::minmax(static_cast<int>(v), w)])
          if (seen.insert(g).second) todo.insert(g);
      }
    }
    c.pinched += seen.size() != star[v].size();
  }
  std::vector<int> label(faces.size(), -1);
  for (size_t f0 = 0; f0 < faces.size(); ++f0) {
    if (label[f0] >= 0) continue;
    std::vector<int> todo{static_cast<int>(f0)};
    label[f0] = static_cast<int>(c.components++);
    while (!todo.empty()) {
      const int f = todo.back();
      todo.pop_back();
      for (int k = 0; k < 3; ++k)
        for (const int g : edges[std::minmax(faces[static_cast<size_t>(f)][static_cast<size_t>(k)], faces[static_cast<size_t>(f)][static_cast<size_t>((k + 1) % 3)])])
          if (label[static_cast<size_t>(g)] < 0) label[static_cast<size_t>(g)] = label[f0], todo.push_back(g);
    }
  }
  return c;
}

// A binary STL's triangles, three corners each (not welded), read here rather than by the
// project's loader.
inline mesh::SurfaceMesh read_binary_stl(const std::string& bytes) {
  mesh::SurfaceMesh s;
  std::uint32_t n = 0;
  if (bytes.size() < 84) return s;
  std::memcpy(&n, bytes.data() + 80, 4);
  if (bytes.size() != 84 + 50 * static_cast<std::size_t>(n)) return s;
  s.vertices.resize(3 * static_cast<Eigen::Index>(n), 3);
  s.faces.resize(n, 3);
  for (std::uint32_t f = 0; f < n; ++f)
    for (int k = 0; k < 3; ++k) {
      float p[3];
      std::memcpy(p, bytes.data() + 84 + 50 * static_cast<std::size_t>(f) + 12 + 12 * k, 12);
      s.vertices.row(3 * f + k) << p[0], p[1], p[2];
      s.faces(f, k) = static_cast<int>(3 * f + k);
    }
  return s;
}

}  // namespace distlab::test
