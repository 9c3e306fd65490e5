#pragma once
// Distances from a polyhedral surface and from its sharp edges for the graded sizing of the
// mesher (mesher.cpp), in their own header so that tests can hold them against brute force.
#include <CGAL/AABB_segment_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/bbox.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace distlab::kelvin::sizing {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Polyhedron = CGAL::Surface_mesh<K::Point_3>;

// The lattices both distances below keep: a distance d is 1-Lipschitz, so its value at the centre
// c of the lattice cell holding p bounds it from below, d(p) ≥ d(c) − |p − c|, and the lattice
// (cells of `cell` from `origin`) is filled lazily, independently of the order of queries.
struct LatticeCell {
  std::int64_t index[3];
  double centre[3];
};
inline LatticeCell lattice_cell(const double q[3], const double origin[3], double cell) {
  LatticeCell out{};
  for (int k = 0; k < 3; ++k) {
    out.index[k] = static_cast<std::int64_t>(std::floor((q[k] - origin[k]) / cell));
    out.centre[k] = origin[k] + (static_cast<double>(out.index[k]) + 0.5) * cell;
  }
  return out;
}
inline double bound_from_centre(double at_centre, const double q[3], const double c[3]) {
  return at_centre - std::sqrt((q[0] - c[0]) * (q[0] - c[0]) + (q[1] - c[1]) * (q[1] - c[1]) + (q[2] - c[2]) * (q[2] - c[2]));
}

// Distance in y from the inverted surface for the graded sizing. An exact AABB query costs up
// to a millisecond deep inside (from near the centre of a sphere-like Ω_inv every triangle is
// about as far), so away from the surface the lattice bound stands in (lattice_cell): the mesh is
// never coarser than graded, and deterministic.
// The queries are CGAL's closest-point search (AABB_tree::closest_point(x, hint): the same
// projections and replacement rule) with shortcuts that do not change its result: a triangle
// whose plane is farther than the current bound is not projected (its distance is at least its
// plane's), boxes are tested in doubles, and a cell starts from its parent cell's closest
// point, a point on the surface, instead of a k-d tree search. These queries took ~60% of graded
// meshing (profiled), mostly projecting triangles that could not be the closest.
class SurfaceDistance {
 public:
  explicit SurfaceDistance(const Polyhedron& poly) {
    const auto box = CGAL::Polygon_mesh_processing::bbox(poly);
    lo_[0] = box.xmin(), lo_[1] = box.ymin(), lo_[2] = box.zmin();
    cell_ = std::max({box.xmax() - box.xmin(), box.ymax() - box.ymin(), box.zmax() - box.zmin()}) / 256;
    triangles_.reserve(poly.number_of_faces());
    planes_.reserve(poly.number_of_faces());
    for (const auto f : poly.faces()) {
      const auto h = poly.halfedge(f);
      // The vertex order of the domain's own face primitives (Triangle_from_face_descriptor_map),
      // so projections round alike.
      const K::Point_3 &a = poly.point(poly.target(h)), &b = poly.point(poly.target(poly.next(h))),
                       &c = poly.point(poly.source(h));
      triangles_.emplace_back(a, b, c);
      const K::Vector_3 n = CGAL::cross_product(b - a, c - a);
      const double len = std::sqrt(CGAL::to_double(n.squared_length()));
      // A degenerate triangle has no plane to skip it by: distance 0 never exceeds a bound.
      const K::Vector_3 u = len > 0 ? n / len : K::Vector_3(0, 0, 0);
      planes_.push_back({u.x(), u.y(), u.z(), CGAL::to_double(u * (a - CGAL::ORIGIN))});
    }
    tree_.insert(triangles_.begin(), triangles_.end());
    tree_.build();
    tree_.accelerate_distance_queries();
  }
  // Lattices of 32, 64, 128 and 256 cells across, each consulted only where its parent's cell
  // centre lies within 4 of the parent's cells of the surface: a point answers by the bound of
  // the coarsest cell that is more than 4 cells from the surface, or exactly within 4 of the
  // finest. A shell 8 cells thick per level, instead of a 32-cell shell of the finest (two
  // levels, before): 0.6x the exact queries and graded meshing 0.75x on the cube at l_x 0.02
  // (distlab-bench-kelvin --mesher), 2.7% more vertices (the looser bounds 4-32 cells out).
  double operator()(const K::Point_3& p) const {
    const double q[3] = {CGAL::to_double(p.x()), CGAL::to_double(p.y()), CGAL::to_double(p.z())};
    const Cell* parent = nullptr;
    for (int level = 0; level < kLevels; ++level) {
      const double cell = cell_ * static_cast<double>(1 << (kLevels - 1 - level));
      const LatticeCell at = lattice_cell(q, lo_, cell);
      const double* c = at.centre;
      // A cell starts from its parent's closest point (a start as good as the nearest vertex
      // from CGAL's k-d tree, measured, and free); a coarsest one from that vertex.
      auto fill = [&] {
        const K::Point_3 centre(c[0], c[1], c[2]);
        Cell fresh;
        fresh.closest = closest(centre, parent != nullptr ? parent->closest : tree_.best_hint(centre).first);
        fresh.distance = std::sqrt(CGAL::to_double(CGAL::squared_distance(centre, fresh.closest)));
        return fresh;
      };
      Cell local;  // a cell another thread is filling: computed here too (the same value)
      const Cell* at_cell = cell_at(lattices_[static_cast<std::size_t>(level)], at, fill, local);
      if (at_cell->distance > 4 * cell) return bound_from_centre(at_cell->distance, q, c);
      parent = at_cell;
    }
    // Near the surface: exact, from the cell centre's closest point.
    return std::sqrt(CGAL::to_double(CGAL::squared_distance(p, closest(p, parent->closest))));
  }

 private:
  using Triangles = std::vector<K::Triangle_3>;
  using Traits = CGAL::AABB_traits<K, CGAL::AABB_triangle_primitive<K, Triangles::const_iterator>>;
  using Tree = CGAL::AABB_tree<Traits>;
  struct Plane {
    double nx, ny, nz, offset;  // unit normal, n · a
  };
  struct Cell {
    double distance = 0;
    K::Point_3 closest;
  };

  static constexpr int kLevels = 4;
  // A slot is filled once: empty → being written (by one thread) → ready.
  static constexpr std::uint8_t kEmpty = 0, kWriting = 1, kReady = 2;
  struct Slot {
    std::atomic<std::uint8_t> state{kEmpty};
    Cell cell;
  };
  // One lattice's cells (n across the bounding box, and a margin of kMargin beyond it), kept in
  // blocks of 4³ allocated when one of their cells is first asked for: the finer lattices are
  // asked only near the surface. A lookup is a block pointer and a slot; TBB's concurrent hash
  // map, before, cost a third of the surface distance's time (profiled), and graded meshing of
  // the cube at l_x 0.02 took 0.9x with this (distlab-bench-kelvin --mesher, the same meshes).
  class Lattice {
   public:
    explicit Lattice(std::int64_t n) : side_((n + 2 * kMargin) / kBlock), blocks_(std::make_unique<std::atomic<Slot*>[]>(static_cast<std::size_t>(side_ * side_ * side_))) {}
    Lattice(const Lattice&) = delete;
    Lattice& operator=(const Lattice&) = delete;
    ~Lattice() {
      for (std::int64_t b = 0; b < side_ * side_ * side_; ++b) delete[] blocks_[static_cast<std::size_t>(b)].load();
    }
    // The cell's slot, nullptr beyond the margin (a query far out).
    Slot* slot(const std::int64_t index[3]) const {
      std::int64_t block = 0, within = 0;
      for (int k = 0; k < 3; ++k) {
        const std::int64_t i = index[k] + kMargin;
        if (i < 0 || i >= side_ * kBlock) return nullptr;
        block = block * side_ + i / kBlock;
        within = within * kBlock + i % kBlock;
      }
      std::atomic<Slot*>& at = blocks_[static_cast<std::size_t>(block)];
      Slot* slots = at.load(std::memory_order_acquire);
      if (slots == nullptr) {
        auto fresh = std::make_unique<Slot[]>(kBlock * kBlock * kBlock);
        if (at.compare_exchange_strong(slots, fresh.get(), std::memory_order_acq_rel)) slots = fresh.release();  // else another thread's
      }
      return &slots[within];
    }

   private:
    static constexpr std::int64_t kBlock = 4, kMargin = 8;
    std::int64_t side_;  // blocks across
    std::unique_ptr<std::atomic<Slot*>[]> blocks_;
  };
  template <class Fill>
  static const Cell* cell_at(const Lattice& lattice, const LatticeCell& at, Fill&& fill, Cell& local) {
    Slot* slot = lattice.slot(at.index);
    if (slot == nullptr) {  // far beyond the box: not kept
      local = fill();
      return &local;
    }
    if (slot->state.load(std::memory_order_acquire) == kReady) return &slot->cell;
    std::uint8_t empty = kEmpty;
    if (slot->state.compare_exchange_strong(empty, kWriting, std::memory_order_acq_rel)) {
      slot->cell = fill();
      slot->state.store(kReady, std::memory_order_release);
      return &slot->cell;
    }
    local = fill();
    return &local;
  }

  // AABB_tree::closest_point(x, hint) (CGAL's Projection_traits) with the plane test in front.
  class Search {
   public:
    Search(const SurfaceDistance& s, const K::Point_3& x, const K::Point_3& hint) : s_(s), closest_(hint) { bound(x); }
    bool go_further() const { return true; }
    void intersection(const K::Point_3& x, const Traits::Primitive& primitive) {
      const Plane& pl = s_.planes_[static_cast<std::size_t>(primitive.id() - s_.triangles_.begin())];
      const double h = pl.nx * CGAL::to_double(x.x()) + pl.ny * CGAL::to_double(x.y()) + pl.nz * CGAL::to_double(x.z()) - pl.offset;
      if (std::abs(h) > reach_) return;
      const K::Point_3 p = s_.tree_.traits().closest_point_object()(x, primitive, closest_);
      if (!s_.tree_.traits().equal_3_object()(p, closest_)) {
        closest_ = p;
        bound(x);
      }
    }
    // CGAL's test (the bound's sphere meets the box) in doubles, widened by the margin: it
    // visits every box CGAL's exact test visits.
    bool do_intersect(const K::Point_3& x, const CGAL::AABB_node<Traits>& node) const {
      return box_distance2(x, node.bbox()) <= reach_ * reach_;
    }
    // The nearer child first (AABB_tree::traversal_with_priority): the bound falls sooner, so
    // fewer boxes and triangles are visited than in the tree's left-first order. The distance is
    // the same: every triangle that could be closest is still projected (meshes bit-identical,
    // distlab-bench-kelvin --mesher's digests).
    using Priority = double;
    std::pair<bool, Priority> do_intersect_with_priority(const K::Point_3& x, const CGAL::AABB_node<Traits>& node) const {
      const double d2 = box_distance2(x, node.bbox());
      return {d2 <= reach_ * reach_, -d2};
    }
    const K::Point_3& closest() const { return closest_; }

   private:
    static double box_distance2(const K::Point_3& x, const CGAL::Bbox_3& b) {
      const double q[3] = {CGAL::to_double(x.x()), CGAL::to_double(x.y()), CGAL::to_double(x.z())};
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double e = std::max({b.min(k) - q[k], q[k] - b.max(k), 0.0});
        d2 += e * e;
      }
      return d2;
    }
    // Skip a triangle or box only if it is farther than the bound by far more than rounding (a
    // rounded projection sits ~1e-16 |x| off its triangle).
    void bound(const K::Point_3& x) {
      const double d = std::sqrt(CGAL::to_double(CGAL::squared_distance(x, closest_)));
      const double size = std::max({std::abs(CGAL::to_double(x.x())), std::abs(CGAL::to_double(x.y())), std::abs(CGAL::to_double(x.z())), d});
      reach_ = d + 1e-9 * (1 + size);
    }
    const SurfaceDistance& s_;
    K::Point_3 closest_;
    double reach_ = 0;
  };

  K::Point_3 closest(const K::Point_3& x, const K::Point_3& hint) const {
    Search search(*this, x, hint);
    tree_.traversal_with_priority(x, search);
    return search.closest();
  }

  Triangles triangles_;
  std::vector<Plane> planes_;
  Tree tree_;
  double lo_[3] = {0, 0, 0}, cell_ = 1;
  std::array<Lattice, kLevels> lattices_{Lattice(32), Lattice(64), Lattice(128), Lattice(256)};
};

// Distance in x from the object's sharp edges for the graded sizing's edge factor
// min(√(e_x / radius), 1), which is 1 wherever e_x ≥ radius (the cube: 62% of the evaluations at
// l_x 0.03, 42% at 0.05; more at finer l_x, the radius being 4 l_x). There a lower
// bound stands in for CGAL's exact query (a segment tree): outside the edges' bounding box the
// distance to the box; inside it the lattice bound (lattice_cell), over a bounded flat lattice.
class EdgeDistance {
 public:
  using Segments = std::vector<K::Segment_3>;
  EdgeDistance(Segments segments, double radius) : segments_(std::move(segments)), radius_(radius) {
    if (segments_.empty()) return;
    tree_.insert(segments_.begin(), segments_.end());
    tree_.build();
    tree_.accelerate_distance_queries();
    if (!(radius > 0)) return;  // no lattice: every query exact
    const CGAL::Bbox_3 box = tree_.bbox();
    double scale = radius;
    for (int k = 0; k < 3; ++k) {
      lo_[k] = box.min(k), hi_[k] = box.max(k);
      scale = std::max({scale, std::abs(lo_[k]), std::abs(hi_[k])});
    }
    // Rounding of the distances and of the bounds is ~1e-16 of the coordinates: the bound must
    // clear the radius by far more before the exact query is skipped.
    margin_ = 1e-9 * (1 + scale);
    // Cells of a quarter radius (at most ~2M of them) over the box grown by the radius and a cell:
    // a point that is not in it is farther than the radius from the box.
    cell_ = radius / 4;
    for (;;) {
      std::int64_t total = 1;
      for (int k = 0; k < 3; ++k) {
        origin_[k] = lo_[k] - radius - cell_;
        n_[k] = static_cast<std::int64_t>(std::ceil((hi_[k] - lo_[k] + 2 * (radius + cell_)) / cell_));
        total *= n_[k];
      }
      if (total <= (std::int64_t{1} << 21)) {
        at_centre_ = std::make_unique<std::atomic<double>[]>(static_cast<std::size_t>(total));
        for (std::int64_t i = 0; i < total; ++i) at_centre_[static_cast<std::size_t>(i)].store(-1.0, std::memory_order_relaxed);
        break;
      }
      cell_ *= 1.25;
    }
  }
  EdgeDistance(const EdgeDistance&) = delete;  // the tree points into segments_
  EdgeDistance& operator=(const EdgeDistance&) = delete;
  bool empty() const { return segments_.empty(); }
  // The exact distance (CGAL's AABB_tree::squared_distance) wherever it is below radius, else a
  // value ≥ radius.
  double operator()(const K::Point_3& x) const {
    if (!at_centre_) return exact(x);
    const double bound = lower_bound(x);
    return bound >= radius_ + margin_ ? bound : exact(x);
  }
  double exact(const K::Point_3& x) const { return std::sqrt(CGAL::to_double(tree_.squared_distance(x))); }
  // ≤ the distance up to rounding (margin_).
  double lower_bound(const K::Point_3& x) const {
    const double q[3] = {CGAL::to_double(x.x()), CGAL::to_double(x.y()), CGAL::to_double(x.z())};
    double box2 = 0;  // squared distance to the edges' bounding box
    for (int k = 0; k < 3; ++k) {
      const double e = std::max({lo_[k] - q[k], q[k] - hi_[k], 0.0});
      box2 += e * e;
    }
    const double box = std::sqrt(box2);
    if (!(box < radius_ + cell_)) return box;  // also for x at infinity
    const LatticeCell at = lattice_cell(q, origin_, cell_);
    const std::int64_t* i = at.index;
    for (int k = 0; k < 3; ++k)
      if (i[k] < 0 || i[k] >= n_[k]) return box;
    std::atomic<double>& slot = at_centre_[static_cast<std::size_t>((i[0] * n_[1] + i[1]) * n_[2] + i[2])];
    double centre = slot.load(std::memory_order_relaxed);
    if (centre < 0) {  // any thread computes the same value
      centre = exact(K::Point_3(at.centre[0], at.centre[1], at.centre[2]));
      slot.store(centre, std::memory_order_relaxed);
    }
    return std::max(box, bound_from_centre(centre, q, at.centre));
  }

 private:
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_segment_primitive<K, Segments::const_iterator>>>;
  Segments segments_;
  Tree tree_;
  double radius_, margin_ = 0, cell_ = 1;
  double lo_[3] = {0, 0, 0}, hi_[3] = {0, 0, 0}, origin_[3] = {0, 0, 0};
  std::int64_t n_[3] = {0, 0, 0};
  std::unique_ptr<std::atomic<double>[]> at_centre_;  // -1: not yet computed; thread-safe (SurfaceDistance)
};

}  // namespace distlab::kelvin::sizing
