// The domain's boundary made a closed 2-manifold (TetMesh::in_domain). Mesh_3 marks a cell as in
// the domain by where its circumcentre lies, and nothing makes the union of such cells a manifold:
// near thin parts or near-touching ones two domain cells can meet at an edge or a vertex only,
// with non-domain cells between them. Its boundary facets are the surface the solver's Dirichlet
// condition sits on and the iso-surfaces' closing facets at σ's own levels, so a pinch there made
// exports with edges shared by four faces (CGAL's own manifold criterion, parameters::manifold(),
// stops with a precondition failure on polyhedral domains with features in CGAL 5.5).
#include <algorithm>
#include <numeric>
#include <vector>

#include "distlab/kelvin/tet_mesh.hpp"

namespace distlab::kelvin {
namespace {

// Cells around each vertex (counting sort).
struct Stars {
  std::vector<int> start, cells;
  explicit Stars(const TetMesh& tm) : start(static_cast<size_t>(tm.points.rows()) + 1, 0) {
    for (Eigen::Index c = 0; c < tm.tets.rows(); ++c)
      for (int k = 0; k < 4; ++k) ++start[static_cast<size_t>(tm.tets(c, k)) + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    cells.resize(static_cast<size_t>(start.back()));
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (Eigen::Index c = 0; c < tm.tets.rows(); ++c)
      for (int k = 0; k < 4; ++k) cells[static_cast<size_t>(fill[static_cast<size_t>(tm.tets(c, k))]++)] = static_cast<int>(c);
  }
};

// The cells of v's star split into components of one side (domain or not), joined across the
// faces through v; the hull counts as one cell outside the domain. The boundary is a manifold at
// v exactly when each side is one component (on the sphere around v, a region and its complement
// both connected make a disc; a pinch at an edge through v splits the complement).
class StarComponents {
 public:
  StarComponents(const TetMesh& tm, const Stars& stars) : tm_(tm), stars_(stars) {}

  // Component label per star cell (index into the star), and the number of components per side.
  void label(int v) {
    v_ = v;
    const int* begin = &stars_.cells[static_cast<size_t>(stars_.start[static_cast<size_t>(v)])];
    const int n = stars_.start[static_cast<size_t>(v) + 1] - stars_.start[static_cast<size_t>(v)];
    star_.assign(begin, begin + n);
    parent_.resize(static_cast<size_t>(n) + 1);  // the last one: the hull
    std::iota(parent_.begin(), parent_.end(), 0);
    for (int i = 0; i < n; ++i) {
      const int c = star_[static_cast<size_t>(i)];
      const bool in = side(c);
      for (int k = 0; k < 4; ++k) {
        if (tm_.tets(c, k) == v) continue;  // the face opposite v does not pass through v
        const int m = tm_.neighbours(c, k);
        if (m < 0) {
          if (!in) unite(n, i);  // the hull never becomes a root it did not start as
          continue;
        }
        if (side(m) != in) continue;
        const auto it = std::find(star_.begin(), star_.end(), m);
        unite(i, static_cast<int>(it - star_.begin()));
      }
    }
    components_in = components_out = 0;
    largest_in = -1;
    std::vector<int> size(static_cast<size_t>(n) + 1, 0);
    for (int i = 0; i < n; ++i) ++size[static_cast<size_t>(find(i))];
    for (int i = 0; i < n; ++i) {
      if (find(i) != i) continue;
      if (side(star_[static_cast<size_t>(i)])) {
        ++components_in;
        if (largest_in < 0 || size[static_cast<size_t>(i)] > size[static_cast<size_t>(largest_in)]) largest_in = i;
      } else {
        ++components_out;
      }
    }
    if (hull_touched(n)) ++components_out;
  }

  bool manifold() const { return components_in == 0 || (components_in == 1 && components_out <= 1); }
  const std::vector<int>& star() const { return star_; }
  bool in_largest(int i) { return find(i) == find(largest_in); }

  int components_in = 0, components_out = 0, largest_in = -1;

 private:
  bool side(int c) const { return tm_.in_domain[static_cast<size_t>(c)] != 0; }
  int find(int i) {
    while (parent_[static_cast<size_t>(i)] != i) i = parent_[static_cast<size_t>(i)] = parent_[static_cast<size_t>(parent_[static_cast<size_t>(i)])];
    return i;
  }
  void unite(int a, int b) { parent_[static_cast<size_t>(find(a))] = find(b); }
  // The hull as a component of its own: not joined to an outside cell, but a face through v of an
  // inside cell lies on it.
  bool hull_touched(int n) {
    if (find(n) != n) return false;
    for (const int c : star_)
      for (int k = 0; k < 4; ++k)
        if (tm_.neighbours(c, k) < 0 && tm_.tets(c, k) != v_) return true;
    return false;
  }

  const TetMesh& tm_;
  const Stars& stars_;
  std::vector<int> star_, parent_;
  int v_ = -1;
};

// Whether v's star has cells on both sides (the hull counting as outside).
bool on_boundary(const TetMesh& tm, const Stars& stars, int v) {
  bool in = false, out = false;
  for (int i = stars.start[static_cast<size_t>(v)]; i < stars.start[static_cast<size_t>(v) + 1]; ++i) {
    const int c = stars.cells[static_cast<size_t>(i)];
    (tm.in_domain[static_cast<size_t>(c)] ? in : out) = true;
    for (int k = 0; k < 4 && !out; ++k) out = tm.neighbours(c, k) < 0 && tm.tets(c, k) != v;
    if (in && out) return true;
  }
  return false;
}

}  // namespace

long make_boundary_manifold(TetMesh& tm) {
  const Stars stars(tm);
  StarComponents star(tm, stars);
  const auto np = static_cast<int>(tm.points.rows());
  std::vector<int> work(static_cast<size_t>(np));
  std::iota(work.begin(), work.end(), 0);
  std::vector<char> queued(static_cast<size_t>(np), 1);
  long moved = 0;
  // Cells only ever leave the domain, so this ends; a vertex is looked at again when a cell of its
  // star moves. Leaving (not joining) grows the object by those cells: the safe direction for a
  // barrier, and the cells are between two parts of the object that nearly touch.
  auto drop = [&](int c) {
    tm.in_domain[static_cast<size_t>(c)] = 0;
    ++moved;
    for (int k = 0; k < 4; ++k) {
      const int w = tm.tets(c, k);
      if (!queued[static_cast<size_t>(w)]) {
        queued[static_cast<size_t>(w)] = 1;
        work.push_back(w);
      }
    }
  };
  while (!work.empty()) {
    const int v = work.back();
    work.pop_back();
    queued[static_cast<size_t>(v)] = 0;
    if (!on_boundary(tm, stars, v)) continue;  // most vertices: all in or all out, nothing to label
    star.label(v);
    if (star.manifold()) continue;
    // First keep the largest piece of the domain around v; if the outside is still split (the
    // domain wraps around an outside pocket), v leaves the domain altogether.
    const std::vector<int> cells = star.star();
    if (star.components_in > 1) {
      for (size_t i = 0; i < cells.size(); ++i)
        if (tm.in_domain[static_cast<size_t>(cells[i])] && !star.in_largest(static_cast<int>(i))) drop(cells[i]);
      star.label(v);
      if (star.manifold()) continue;
    }
    for (const int c : cells)
      if (tm.in_domain[static_cast<size_t>(c)]) drop(c);
  }
  return moved;
}

}  // namespace distlab::kelvin
