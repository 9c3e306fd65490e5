// Topological and geometric validation of closed solid boundaries.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <unordered_map>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/cgal_surface.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/weld.hpp"

namespace distlab::mesh {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

std::uint64_t edge_key(int a, int b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | static_cast<std::uint32_t>(std::max(a, b));
}

// Union-find over the faces around one vertex: the star is a disk iff it is one fan.
int find(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

std::vector<std::vector<int>> stars(const SurfaceMesh& mesh) {
  std::vector<std::vector<int>> star(static_cast<size_t>(mesh.vertices.rows()));
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) star[static_cast<size_t>(mesh.faces(f, k))].push_back(static_cast<int>(f));
  return star;
}

// Whether the faces around v (none is harmless) form one fan: joined across edges through v.
bool one_fan(const SurfaceMesh& mesh, const std::vector<int>& faces, int v) {
  if (faces.empty()) return true;
  std::vector<int> parent(faces.size());
  std::iota(parent.begin(), parent.end(), 0);
  // Faces sharing an edge through v are joined; key them by the other edge endpoint.
  std::unordered_map<int, int> by_neighbour;
  for (size_t i = 0; i < faces.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      const int w = mesh.faces(faces[i], k);
      if (w == v) continue;
      auto [it, inserted] = by_neighbour.emplace(w, static_cast<int>(i));
      if (!inserted) parent[static_cast<size_t>(find(parent, static_cast<int>(i)))] = find(parent, it->second);
    }
  const int root = find(parent, 0);
  for (size_t i = 1; i < faces.size(); ++i)
    if (find(parent, static_cast<int>(i)) != root) return false;
  return true;
}

// Per face, its piece (faces joined across shared edges), numbered from 0 in face order.
std::vector<int> face_pieces(const SurfaceMesh& mesh) {
  std::vector<int> parent(static_cast<size_t>(mesh.faces.rows()));
  std::iota(parent.begin(), parent.end(), 0);
  std::unordered_map<std::uint64_t, int> first_face;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      auto [it, inserted] = first_face.emplace(edge_key(mesh.faces(f, k), mesh.faces(f, (k + 1) % 3)), static_cast<int>(f));
      if (!inserted) parent[static_cast<size_t>(find(parent, static_cast<int>(f)))] = find(parent, it->second);
    }
  std::vector<int> label(parent.size(), -1), piece(parent.size());
  int n = 0;
  for (size_t f = 0; f < parent.size(); ++f) {
    int& l = label[static_cast<size_t>(find(parent, static_cast<int>(f)))];
    if (l < 0) l = n++;
    piece[f] = l;
  }
  return piece;
}

}  // namespace

SurfaceMesh largest_piece(const SurfaceMesh& mesh, long* pieces) {
  const std::vector<int> piece = face_pieces(mesh);
  const int n = piece.empty() ? 0 : *std::max_element(piece.begin(), piece.end()) + 1;
  if (pieces != nullptr) *pieces = n;
  std::vector<double> volume(static_cast<size_t>(n), 0.0);  // divergence theorem, per piece
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Vec3 a = mesh.vertices.row(mesh.faces(f, 0)), b = mesh.vertices.row(mesh.faces(f, 1)), c = mesh.vertices.row(mesh.faces(f, 2));
    volume[static_cast<size_t>(piece[static_cast<size_t>(f)])] += a.dot(b.cross(c)) / 6.0;
  }
  int best = 0;
  for (int i = 1; i < n; ++i)
    if (std::abs(volume[static_cast<size_t>(i)]) > std::abs(volume[static_cast<size_t>(best)])) best = i;
  std::vector<int> to(static_cast<size_t>(mesh.vertices.rows()), -1);
  SurfaceMesh out;
  long nf = 0, nv = 0;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) nf += piece[static_cast<size_t>(f)] == best;
  out.faces.resize(nf, 3);
  nf = 0;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
    if (piece[static_cast<size_t>(f)] == best)
      for (int k = 0; k < 3; ++k) to[static_cast<size_t>(mesh.faces(f, k))] = 0;  // used
  for (int& v : to)
    if (v == 0) v = static_cast<int>(++nv);  // in the mesh's vertex order, from 1 here
  for (int& v : to) --v;
  out.vertices.resize(nv, 3);
  for (Eigen::Index v = 0; v < mesh.vertices.rows(); ++v)
    if (to[static_cast<size_t>(v)] >= 0) out.vertices.row(to[static_cast<size_t>(v)]) = mesh.vertices.row(v);
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
    if (piece[static_cast<size_t>(f)] == best) {
      for (int k = 0; k < 3; ++k) out.faces(nf, k) = to[static_cast<size_t>(mesh.faces(f, k))];
      ++nf;
    }
  return out;
}

SurfaceReport inspect_surface(const SurfaceMesh& mesh) {
  SurfaceReport r;
  r.faces = static_cast<long>(mesh.faces.rows());
  // Welded at float32: what an STL or glTF file of the surface carries, the coarsest the
  // project writes, so a surface that passes here passes as any of its files.
  SurfaceMesh rounded = mesh;
  rounded.vertices = mesh.vertices.cast<float>().cast<double>();
  const SurfaceMesh w = weld(rounded).surface;
  r.vertices = static_cast<long>(w.vertices.rows());
  std::unordered_map<std::uint64_t, int> edges;
  for (Eigen::Index f = 0; f < w.faces.rows(); ++f) {
    const int a = w.faces(f, 0), b = w.faces(f, 1), c = w.faces(f, 2);
    if (a == b || b == c || c == a) {
      ++r.degenerate_faces;
      continue;
    }
    for (int k = 0; k < 3; ++k) ++edges[edge_key(w.faces(f, k), w.faces(f, (k + 1) % 3))];
  }
  for (const auto& [key, count] : edges) {
    if (count == 1) ++r.boundary_edges;
    else if (count > 2) ++r.non_manifold_edges;
  }
  const std::vector<std::vector<int>> star = stars(w);
  for (int v = 0; v < static_cast<int>(w.vertices.rows()); ++v)
    if (!one_fan(w, star[static_cast<size_t>(v)], v)) ++r.non_manifold_vertices;
  std::vector<int> piece = face_pieces(w);
  r.components = piece.empty() ? 0 : *std::max_element(piece.begin(), piece.end()) + 1;
  r.volume = r.faces > 0 ? signed_volume(mesh) : 0.0;
  return r;
}

std::string surface_defects(const SurfaceReport& r) {
  if (r.faces == 0) return "no faces";
  std::string out;
  auto add = [&out](long n, const char* one, const char* many) {
    if (n == 0) return;
    out += (out.empty() ? "" : ", ") + std::to_string(n) + " " + (n == 1 ? one : many);
  };
  add(r.boundary_edges, "edge in one face only (open)", "edges in one face only (open)");
  add(r.non_manifold_edges, "edge in more than two faces", "edges in more than two faces");
  add(r.non_manifold_vertices, "vertex where two sheets touch", "vertices where two sheets touch");
  add(r.degenerate_faces, "face collapsed at float32 precision", "faces collapsed at float32 precision");
  return out;
}

MeshDefects find_defects(const SurfaceMesh& user, std::size_t max_items) {
  MeshDefects d;
  const Welded welded = weld(user);
  const SurfaceMesh& w = welded.surface;
  const auto nv = static_cast<std::size_t>(w.vertices.rows());
  const auto nf = static_cast<std::size_t>(w.faces.rows());
  // A welded vertex is named by its first file vertex (the refusals' numbering).
  std::vector<int> name(nv, -1);
  for (std::size_t i = 0; i < welded.to_welded.size(); ++i)
    if (const int k = welded.to_welded[i]; k >= 0 && name[static_cast<std::size_t>(k)] < 0) name[static_cast<std::size_t>(k)] = static_cast<int>(i);
  const auto keep = [&](auto& list, auto item) {
    if (list.size() < max_items) list.push_back(item);
    else d.truncated = true;
  };
  const auto pair_of = [&](std::uint64_t key) {
    const int a = name[key >> 32], b = name[key & 0xffffffffu];
    return std::array<int, 2>{std::min(a, b), std::max(a, b)};
  };
  const double scale = nv > 0 ? (w.vertices.colwise().maxCoeff() - w.vertices.colwise().minCoeff()).norm() : 0.0;
  std::vector<char> degenerate(nf, 0);
  std::unordered_map<std::uint64_t, int> edges;
  edges.reserve(nf * 2);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto r = static_cast<Eigen::Index>(f);
    const int a = w.faces(r, 0), b = w.faces(r, 1), c = w.faces(r, 2);
    const Vec3 pa = w.vertices.row(a), pb = w.vertices.row(b), pc = w.vertices.row(c);
    const bool repeated = a == b || b == c || c == a;
    // The zero-area rule of require_closed_manifold.
    if (repeated || (pb - pa).cross(pc - pa).norm() <= 1e-14 * scale * scale) {
      degenerate[f] = 1;
      ++d.degenerate_faces;
      keep(d.degenerate, static_cast<int>(f));
    }
    if (repeated) continue;  // no edges (inspect_surface's rule)
    for (int k = 0; k < 3; ++k) ++edges[edge_key(w.faces(r, k), w.faces(r, (k + 1) % 3))];
  }
  std::vector<std::uint64_t> open, shared;
  for (const auto& [key, count] : edges) {
    if (count == 1) open.push_back(key);
    else if (count > 2) shared.push_back(key);
  }
  d.boundary_edges = static_cast<long>(open.size());
  d.non_manifold_edges = static_cast<long>(shared.size());
  std::vector<std::array<int, 2>> named;
  for (auto* keys : {&open, &shared}) {
    named.clear();
    for (const std::uint64_t key : *keys) named.push_back(pair_of(key));
    std::sort(named.begin(), named.end());
    for (const auto& e : named) keep(keys == &open ? d.boundary : d.non_manifold, e);
  }
  const std::vector<std::vector<int>> star = stars(w);
  std::vector<int> pinched;
  for (std::size_t v = 0; v < nv; ++v)
    if (!one_fan(w, star[v], static_cast<int>(v))) pinched.push_back(name[v]);
  d.non_manifold_vertices = static_cast<long>(pinched.size());
  std::sort(pinched.begin(), pinched.end());
  for (const int v : pinched) keep(d.pinched, v);

  // Pieces, their volumes and their faces as runs; the largest as largest_piece chooses it.
  const std::vector<int> piece = face_pieces(w);
  const int n_pieces = piece.empty() ? 0 : *std::max_element(piece.begin(), piece.end()) + 1;
  d.pieces.resize(static_cast<std::size_t>(n_pieces));
  std::size_t runs = 0;
  int open_piece = -1;  // the piece whose last run ends at face f − 1 (−1: that run is not listed)
  for (std::size_t f = 0; f < nf; ++f) {
    MeshDefects::Piece& p = d.pieces[static_cast<std::size_t>(piece[f])];
    const auto r = static_cast<Eigen::Index>(f);
    const Vec3 a = w.vertices.row(w.faces(r, 0)), b = w.vertices.row(w.faces(r, 1)), c = w.vertices.row(w.faces(r, 2));
    p.volume += a.dot(b.cross(c)) / 6.0;
    ++p.faces;
    if (open_piece == piece[f]) {
      ++p.runs.back()[1];
    } else if (runs < max_items) {
      p.runs.push_back({static_cast<long>(f), 1});
      ++runs;
      open_piece = piece[f];
    } else {
      d.truncated = true;
      open_piece = -1;
    }
  }
  for (int i = 0; i < n_pieces; ++i)
    if (d.largest < 0 || std::abs(d.pieces[static_cast<std::size_t>(i)].volume) > std::abs(d.pieces[static_cast<std::size_t>(d.largest)].volume)) d.largest = i;

  // Self-intersections among the faces a halfedge mesh takes (face i of it: row of_face[i]).
  using Mesh = CGAL::Surface_mesh<K::Point_3>;
  Mesh sm;
  std::vector<Mesh::Vertex_index> vi;
  vi.reserve(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const auto r = static_cast<Eigen::Index>(v);
    vi.push_back(sm.add_vertex(K::Point_3(w.vertices(r, 0), w.vertices(r, 1), w.vertices(r, 2))));
  }
  std::vector<int> of_face;
  for (std::size_t f = 0; f < nf; ++f) {
    const auto r = static_cast<Eigen::Index>(f);
    const auto at = [&](int k) { return vi[static_cast<std::size_t>(w.faces(r, k))]; };
    if (degenerate[f] || sm.add_face(at(0), at(1), at(2)) == Mesh::null_face()) {
      ++d.unchecked_faces;
      continue;
    }
    of_face.push_back(static_cast<int>(f));
  }
  std::vector<std::pair<Mesh::Face_index, Mesh::Face_index>> pairs;
  if (max_items > 0 && sm.number_of_faces() > 1)
    CGAL::Polygon_mesh_processing::self_intersections(sm, std::back_inserter(pairs),
                                                      CGAL::parameters::maximum_number(static_cast<unsigned>(std::min<std::size_t>(max_items, 1u << 30))));
  d.self_intersections = static_cast<long>(pairs.size());
  d.self_intersections_complete = max_items > 0 && pairs.size() < max_items;
  for (const auto& [f, g] : pairs) {
    const int a = of_face[f.idx()], b = of_face[g.idx()];
    d.intersecting.push_back({std::min(a, b), std::max(a, b)});
  }
  std::sort(d.intersecting.begin(), d.intersecting.end());
  if (!d.self_intersections_complete && nf > 1) d.truncated = true;
  return d;
}

namespace {
// Per undirected edge (edge_key): the number of faces, and the balance of its two directions.
struct EdgeUse {
  int count = 0;
  int forward = 0;
};
std::unordered_map<std::uint64_t, EdgeUse> edge_uses(const SurfaceMesh& mesh) {
  const auto nf = static_cast<int>(mesh.faces.rows());
  std::unordered_map<std::uint64_t, EdgeUse> edges;
  edges.reserve(static_cast<size_t>(nf) * 2);
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = mesh.faces(f, k), b = mesh.faces(f, (k + 1) % 3);
      EdgeUse& use = edges[edge_key(a, b)];
      ++use.count;
      use.forward += a < b ? 1 : -1;
    }
  return edges;
}
}  // namespace

std::string repair_advice(const SurfaceMesh& mesh) {
  bool open = false, fins = false;
  for (const auto& [key, use] : edge_uses(mesh)) {
    open = open || use.count == 1;
    fins = fins || use.count > 2;
  }
  // fix's stitching and hole filling leave an edge of three or more faces (a fin) crossing the
  // surface (Fix.AFinIsLeftAndTheAdviceIsWrap); holes it fills only up to max_hole_edges (default none).
  if (fins) return "\"repair\": \"wrap\" can make it one (\"fix\" cannot: an edge has more than two faces)";
  if (open) return "\"repair\": \"wrap\", or \"fix\" with repair_options.max_hole_edges at least each hole's edge count, can make it one";
  return "\"repair\": \"fix\" or \"wrap\" can make it one";
}

std::string topology_defect(const SurfaceMesh& mesh, const std::vector<int>& names) {
  const auto name = [&](std::uint64_t v) {
    return std::to_string(v < names.size() ? static_cast<std::uint64_t>(names[v]) : v);
  };
  const auto nv = static_cast<int>(mesh.vertices.rows());
  const auto nf = static_cast<int>(mesh.faces.rows());
  if (nf == 0) return "mesh has no triangles";
  for (int f = 0; f < nf; ++f) {
    const int a = mesh.faces(f, 0), b = mesh.faces(f, 1), c = mesh.faces(f, 2);
    if (std::min({a, b, c}) < 0 || std::max({a, b, c}) >= nv)
      return file_face_name(mesh, f) + " has a vertex index out of range";
    if (a == b || b == c || c == a) return "degenerate " + file_face_name(mesh, f) + " (repeated vertex)";
  }
  const auto edges = edge_uses(mesh);
  size_t boundary = 0;
  std::uint64_t first_boundary = 0, non_manifold = 0, flipped = 0;
  bool have_non_manifold = false, have_flipped = false;
  for (const auto& [key, use] : edges) {
    if (use.count == 1) {
      if (boundary++ == 0 || key < first_boundary) first_boundary = key;
    } else if (use.count > 2 && (!have_non_manifold || key < non_manifold)) {
      non_manifold = key, have_non_manifold = true;
    } else if (use.count == 2 && use.forward != 0 && (!have_flipped || key < flipped)) {
      flipped = key, have_flipped = true;
    }
  }
  auto edge_name = [&](std::uint64_t key) { return "(" + name(key >> 32) + ", " + name(key & 0xffffffffu) + ")"; };
  // OBJ counts its vertices from 1: say which count these are.
  const std::string numbering = "; vertices counted from 0 in the file's order";
  if (boundary > 0)
    return std::to_string(boundary) + " boundary edge" + (boundary > 1 ? "s" : "") +
           " (not closed), first at edge " + edge_name(first_boundary) + numbering;
  if (have_non_manifold)
    return "non-manifold edge at vertex " + name(non_manifold >> 32) + " (edge " +
           edge_name(non_manifold) + " has more than two faces)" + numbering;
  if (have_flipped)
    return "inconsistently oriented faces at edge " + edge_name(flipped) + numbering;

  // Non-manifold vertices: the faces around a vertex must form a single fan.
  const std::vector<std::vector<int>> star = stars(mesh);
  for (int v = 0; v < nv; ++v)
    if (!one_fan(mesh, star[static_cast<size_t>(v)], v))
      return "non-manifold vertex " + name(static_cast<std::uint64_t>(v)) + " (two surface sheets touch there)";
  return {};
}

void require_closed_manifold(SurfaceMesh& mesh, const std::string& field,
                             const CheckOptions& options) {
  if (!mesh.vertices.allFinite())
    throw InvalidInput(field, "mesh has non-finite vertex coordinates");
  if (std::string defect = topology_defect(mesh); !defect.empty())
    throw InvalidInput(field, "mesh is not a closed manifold surface: " + defect);
  const double scale = (mesh.vertices.colwise().maxCoeff() - mesh.vertices.colwise().minCoeff()).norm();
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Vec3 a = mesh.vertices.row(mesh.faces(f, 0));
    const Vec3 b = mesh.vertices.row(mesh.faces(f, 1));
    const Vec3 c = mesh.vertices.row(mesh.faces(f, 2));
    if ((b - a).cross(c - a).norm() <= 1e-14 * scale * scale)
      throw InvalidInput(field, "degenerate (zero-area) " + file_face_name(mesh, f));
  }
  if (options.self_intersection) {
    Eigen::Index rejected = -1;
    const CGAL::Surface_mesh<K::Point_3> sm = to_cgal_surface<K::Point_3>(mesh, &rejected);
    if (rejected >= 0)
      throw InvalidInput(field, "mesh is not a closed manifold surface: " + file_face_name(mesh, rejected) +
                                    " cannot be added to a halfedge mesh");
    std::vector<std::pair<CGAL::Surface_mesh<K::Point_3>::Face_index,
                          CGAL::Surface_mesh<K::Point_3>::Face_index>>
        pairs;
    CGAL::Polygon_mesh_processing::self_intersections(sm, std::back_inserter(pairs));
    if (!pairs.empty()) {
      auto [f, g] = *std::min_element(pairs.begin(), pairs.end(), [](auto& p, auto& q) {
        return std::minmax(p.first, p.second) < std::minmax(q.first, q.second);
      });
      throw InvalidInput(field, "self-intersection: " + std::to_string(pairs.size()) +
                                    " pair(s) of intersecting triangles, first " +
                                    file_face_name(mesh, std::min(f, g).idx()) + " and " +
                                    file_face_name(mesh, std::max(f, g).idx()));
    }
  }
  if (signed_volume(mesh) < 0) mesh.faces.col(1).swap(mesh.faces.col(2));
}

}  // namespace distlab::mesh
