#pragma once
// Allocator for the large arrays a hint-less query reads at random (packed cells and vertices,
// the seeding grid), and for the factor's values the solves stream: blocks of 2 MB or more are 2 MB aligned and marked MADV_HUGEPAGE, so that
// transparent huge pages back them where the kernel allows it ("madvise" mode, Debian's
// default). A random access into 100 MB of 4 KB pages misses the TLB almost every time, and on
// a VM each miss is a two-level page walk; with 2 MB pages the TLB covers the whole mesh.
// Without huge pages (kernel setting, or none free) the memory is ordinary: same contents.
// DISTLAB_HUGE_PAGES=0 in the environment leaves the advice out (A/B runs of the benchmarks), and
// the executables' huge-page heap with it (app's huge_page_heap.hpp).
#include <sys/mman.h>

#include <cstddef>
#include <cstdlib>
#include <new>
#include <string_view>
#include <vector>

namespace distlab::kelvin {

template <class T>
struct HugePageAllocator {
  using value_type = T;
  static constexpr std::size_t kHugePage = std::size_t{2} << 20;

  HugePageAllocator() = default;
  template <class U>
  HugePageAllocator(const HugePageAllocator<U>&) noexcept {}

  T* allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
    if (bytes < kHugePage) return static_cast<T*>(::operator new(bytes, std::align_val_t(alignof(T))));
    void* p = huge_page_malloc(bytes);
    if (!p) throw std::bad_alloc();
    return static_cast<T*>(p);
  }
  // malloc with the same advice for blocks of 2 MB or more (std::free releases either); nullptr
  // when out of memory. Also CHOLMOD's allocator (cholmod_solver.cpp).
  static void* huge_page_malloc(std::size_t bytes) noexcept {
    if (bytes < kHugePage) return std::malloc(bytes);
    const std::size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
    void* p = std::aligned_alloc(kHugePage, rounded);
    if (p != nullptr && advise()) ::madvise(p, rounded, MADV_HUGEPAGE);  // advice only: failure leaves 4 KB pages
    return p;
  }
  void deallocate(T* p, std::size_t n) noexcept {
    if (n * sizeof(T) < kHugePage)
      ::operator delete(p, std::align_val_t(alignof(T)));
    else
      std::free(p);
  }
  static bool advise() {
    static const bool on = [] {
      const char* v = std::getenv("DISTLAB_HUGE_PAGES");
      return v == nullptr || std::string_view(v) != "0";
    }();
    return on;
  }
  template <class U>
  bool operator==(const HugePageAllocator<U>&) const noexcept {
    return true;
  }
};

template <class T>
using HugeVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace distlab::kelvin
