#pragma once
// Mesh_3's lazy sorted refinement queues (CGAL_MESH_3_USE_LAZY_SORTED_REFINEMENT_QUEUE) as binary
// heaps instead of a std::multimap. Replaces, for one thread (Sequential_tag) only, CGAL 5.5's
// CGAL::Meshes::Filtered_multimap_container (<CGAL/Meshes/Filtered_multimap_container.h>, the
// container Mesh_3's Refine_cells_3 and Refine_facets_3 use for those queues), keeping its
// interface. CGAL's container pops the smallest quality first, equal qualities in insertion order
// (multimap::insert places an element after its equals); the heap orders by (quality, insertion
// number), so it pops the same elements in the same order and the mesh is the same bit for bit.
// Why: the multimap allocated a node per bad element and walked a red-black tree per insertion;
// with the allocator's frees and consolidation that was ~25% of graded meshing (perf, cube l_x
// 0.02). Include before any Mesh_3 header is instantiated; mesher.cpp is the only translation
// unit that does.
// These first: with TBB, Filtered_multimap_container.h uses Parallel_tag and CGAL_assertion
// without including them.
#include <CGAL/assertions.h>
#include <CGAL/tags.h>

#include <CGAL/Meshes/Filtered_multimap_container.h>

#include <cstdint>
#include <functional>
#include <queue>
#include <tuple>
#include <utility>
#include <vector>

namespace CGAL::Meshes {

template <typename Element_, typename Quality_, typename Predicate>
class Filtered_multimap_container<Element_, Quality_, Predicate, CGAL::Sequential_tag> {
 public:
  using Quality = Quality_;
  using Element = Element_;
  using value_type = std::pair<Quality, Element>;
  using size_type = std::size_t;

  Filtered_multimap_container() = default;
  explicit Filtered_multimap_container(const Predicate& p) : test_(p) {}
  explicit Filtered_multimap_container(bool) {}
  Filtered_multimap_container(const Predicate& p, bool) : test_(p) {}

  // The parallel interface (Filtered_multimap_container_base<…, Sequential_tag>: nothing to do).
  void add_to_TLS_lists_impl(bool) {}
  Element get_next_local_element_impl() { return Element(); }
  value_type get_next_local_raw_element_impl() { return value_type(); }
  void pop_next_local_element_impl() {}
  void splice_local_lists_impl() {}
  bool no_longer_local_element_to_refine_impl() { return true; }

  void insert_raw_element(const value_type& re) { heap_.push(Entry{re.first, next_++, re.second}); }
  void add_bad_element(const Element& e, const Quality& q) { heap_.push(Entry{q, next_++, e}); }
  bool no_longer_element_to_refine_impl() {
    while (!heap_.empty() && !test_(heap_.top().element)) heap_.pop();
    return heap_.empty();
  }
  Element get_next_element_impl() const { return heap_.top().element; }
  value_type get_next_raw_element_impl() { return {heap_.top().quality, heap_.top().element}; }
  void pop_next_element_impl() { heap_.pop(); }
  size_type size() const { return heap_.size(); }
  void clear() { heap_ = Heap(); }
  bool is_zombie(const Element& e) const { return !test_(e); }

 private:
  struct Entry {
    Quality quality;
    std::uint64_t order;
    Element element;
    // std::priority_queue pops the largest: the largest here is the smallest (quality, order).
    bool operator<(const Entry& o) const { return std::tie(o.quality, o.order) < std::tie(quality, order); }
  };
  using Heap = std::priority_queue<Entry, std::vector<Entry>>;
  Heap heap_;
  std::uint64_t next_ = 0;
  Predicate test_;
};

}  // namespace CGAL::Meshes
