#pragma once
// Forward and back substitution over a supernodal Cholesky factor (CHOLMOD's structure, the values
// in the solve's own order), split over two lanes of the elimination tree so that two cores can
// share one solve.
//
// Disjoint subtrees of the supernodal elimination tree are independent in both passes: a
// supernode's forward update only reaches its ancestors, and its back substitution only reads
// them. So the plan deals subtrees to two lanes, balanced by the factor entries they read, and
// keeps the rest (the top separators, the ancestors of every dealt subtree) for one lane after
// them (forward) or before them (back). The only shared writes are lane 1's forward updates of
// top rows: they go to a private buffer, subtracted afterwards. The arithmetic is the same
// whether lane 1 runs on a second thread or after lane 0, so the result does not depend on the
// number of threads.
#include <algorithm>
#include <array>
#include <cstdlib>
#include <memory>
#include <new>
#include <utility>
#include <vector>

#include "huge_pages.hpp"

namespace distlab::kelvin {

// The structure of a supernodal factor L (CHOLMOD names): supernode k owns columns
// super[k] … super[k+1]−1; its rows are s[pi[k]] … s[pi[k+1]−1] (its own columns first). CHOLMOD
// keeps its values as the dense column-major block x[px[k]] … with pi[k+1]−pi[k] rows; the solve
// reads them in its own order instead (SolveValues), from `values + start[k]`.
struct SupernodalFactor {
  int n = 0, nsuper = 0;
  const int *super = nullptr, *pi = nullptr, *px = nullptr, *s = nullptr;
  const double* values = nullptr;
  const long* start = nullptr;
};

// One array from malloc (huge-page advised; std::free releases it).
class ValueArray {
 public:
  ValueArray() = default;
  ValueArray(double* adopted, std::size_t size) : data_(adopted), size_(size) {}
  double* data() { return data_.get(); }
  const double* data() const { return data_.get(); }
  std::size_t size() const { return size_; }
  const double* begin() const { return data(); }
  const double* end() const { return data() + size_; }
  // realloc: the first min(n, size()) values stay; std::bad_alloc if it cannot grow (unchanged).
  void resize(std::size_t n) {
    auto* p = static_cast<double*>(std::realloc(data_.get(), std::max<std::size_t>(n, 1) * sizeof(double)));
    if (p == nullptr && n > size_) throw std::bad_alloc();
    if (p != nullptr) {
      (void)data_.release();  // realloc freed or kept it
      data_.reset(p);
    }
    size_ = n;  // a shrink that failed keeps the larger block
  }

 private:
  struct Free {
    void operator()(double* p) const noexcept { std::free(p); }
  };
  std::unique_ptr<double, Free> data_;
  std::size_t size_ = 0;
};

// The factor's values in the order a solve reads them. Each supernode is cut into chunks of up to
// 8 columns; a chunk holds its diagonal block (column-major, upper part zero), then the rows below
// it in tiles of 2 rows × the chunk's columns (a pair of rows per column), the last tile padded
// with a zero row. The forward pass reads the whole array in ascending addresses; the back pass
// reads each chunk's tiles from the last one up, then its diagonal block, so it reads the array in
// descending addresses. Either way the hardware prefetcher sees one stream, where CHOLMOD's
// column-major blocks made it follow 8 columns at once and restart at every chunk.
struct SolveValues {
  ValueArray values;
  std::vector<long> start;  // per supernode, and the total at nsuper
};
// x: CHOLMOD's values for the structure f (f.values and f.start are not used), px[nsuper] doubles
// from malloc, which this takes over (freed if it throws) and rewrites into the solve's order.
// No second array of the factor's size: on the cube at l_x 0.02 (886 MB) a copy faulted in 740 MB
// of fresh pages and took 0.73-0.99 s, this 0.37-0.53 s. Supernodes are packed in order; a block
// the output reaches before it was read is set aside first.
SolveValues pack_in_place(const SupernodalFactor& f, double* x);
// For values that arrive one supernode at a time (a stored factor): the layout (a fresh array,
// not yet written; start set), then each supernode's block (CHOLMOD's px[k] … px[k+1]) packed to
// out.values.data() + out.start[k].
SolveValues solve_layout(const SupernodalFactor& f);
void pack_supernode(const SupernodalFactor& f, int k, const double* block, double* v);
// Back to CHOLMOD's layout: supernode k's block (the unused upper triangle of its diagonal block
// zero), and all of them (px[nsuper] doubles).
void unpack_supernode(const SupernodalFactor& f, int k, double* block);
void unpack_values(const SupernodalFactor& f, double* x);

// The entries of supernode k a solve pass needs: the lower triangle of its diagonal block and the
// panel below. (SolveValues also stores the upper parts of the 8 × 8 diagonal blocks and the pad
// rows, which the passes stream without needing; on the cube at l_x 0.05 they add about 1%.
// Bandwidths are counted from these entries, so they leave that out.) Without k: all.
double entries_read(const SupernodalFactor& f, int k);
double entries_read(const SupernodalFactor& f);

struct SolvePlan {
  std::array<std::vector<std::pair<int, int>>, 2> lanes;  // supernode ranges [begin, end), ascending
  std::vector<int> top;                                   // the other supernodes, ascending
  std::vector<unsigned char> top_column;                  // 1 for the columns of top supernodes
  // (heavier lane + top) / all, in factor entries: the two-thread time as a share of one's.
  double critical_share = 1;
};

// Falls back to a single lane holding every supernode if the factor is not postordered.
SolvePlan plan_two_lanes(const SupernodalFactor& f);
SolvePlan plan_one_lane(const SupernodalFactor& f);

struct SolveWorkspace {
  std::array<std::vector<double>, 2> below;  // one supernode's rows (own columns, then below), per lane
  std::vector<double> lane1_top;             // lane 1's forward updates of top rows (zero between solves)
};

// Solves L Lᵀ w = w in place (w permuted, size n; f with its values). The forward pass skips every supernode whose
// part of w is still zero. Lane 1 runs on a second thread if `threads` is true.
// Returns the number of factor entries skipped.
double solve_supernodal(const SupernodalFactor& f, const SolvePlan& plan, double* w, SolveWorkspace& ws,
                        bool threads);

}  // namespace distlab::kelvin
