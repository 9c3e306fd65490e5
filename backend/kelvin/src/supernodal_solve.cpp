#include "supernodal_solve.hpp"

#include <algorithm>
#include <cstring>
#include <numeric>

#include "distlab/geometry/parallel.hpp"

namespace distlab::kelvin {

namespace {

// The kernels walk a supernode in chunks of kChunk columns: the chunk's triangle, then one pass
// down the rows below it reading the chunk's columns side by side, so each entry of the lower
// triangle and of the panel below is read once, kChunk columns as concurrent streams, with
// software prefetch kPrefetch doubles ahead in each (hardware prefetchers stop at every 4 KB
// page of a column). They replace OpenBLAS dtrsv + dgemv per supernode (and Eigen's kernels for
// small ones): on the cube at l_x 0.05 (58 MB read per pass) 0.91–0.96x their CPU time, at
// l_x 0.08 (in cache) 0.51x; medians of 41 solves alternating in one process, same answer to
// 3e-15 relative.
constexpr int kChunk = 8;
constexpr int kPrefetch = 128;
// Two doubles as one SSE2 register (GCC/Clang vector extension): the dot products of the back
// pass are reductions, which the compiler does not vectorise by itself without -ffast-math.
using Pair = double __attribute__((vector_size(16)));
Pair load_pair(const double* p) {
  Pair v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
void prefetch_chunk(const double* const* col, int r) {
  if ((r & 7) == 0)  // once per cache line of each column
    for (int q = 0; q < kChunk; ++q) __builtin_prefetch(col[q] + r + kPrefetch);
}

// u: the supernode's rows (its own columns first). Forward: u_own = L_kk⁻¹ u_own, then
// u_below −= L_below,k u_own.
void forward_block(const double* block, int nrow, int ncol, double* u) {
  for (int j0 = 0; j0 < ncol; j0 += kChunk) {
    const int jb = std::min(kChunk, ncol - j0), r0 = j0 + jb;
    for (int c = j0; c < r0; ++c) {
      const double* col = block + static_cast<long>(c) * nrow;
      const double yc = u[c] /= col[c];
      for (int r = c + 1; r < r0; ++r) u[r] -= col[r] * yc;
    }
    if (jb < kChunk) {
      for (int q = j0; q < r0; ++q) {
        const double* col = block + static_cast<long>(q) * nrow;
        for (int r = r0; r < nrow; ++r) u[r] -= col[r] * u[q];
      }
      continue;
    }
    const double* a[kChunk];
    double y[kChunk];
    for (int q = 0; q < kChunk; ++q) a[q] = block + static_cast<long>(j0 + q) * nrow, y[q] = u[j0 + q];
    for (int r = r0; r < nrow; ++r) {
      prefetch_chunk(a, r);
      u[r] -= ((a[0][r] * y[0] + a[1][r] * y[1]) + (a[2][r] * y[2] + a[3][r] * y[3])) +
              ((a[4][r] * y[4] + a[5][r] * y[5]) + (a[6][r] * y[6] + a[7][r] * y[7]));
    }
  }
}

// Back: u_own = L_kk⁻ᵀ (u_own − L_below,kᵀ u_below), chunks from the last one up.
void backward_block(const double* block, int nrow, int ncol, double* u) {
  for (int j0 = (ncol - 1) / kChunk * kChunk; j0 >= 0; j0 -= kChunk) {
    const int jb = std::min(kChunk, ncol - j0), r0 = j0 + jb;
    double dot[kChunk] = {};
    if (jb < kChunk) {
      for (int q = 0; q < jb; ++q) {
        const double* col = block + static_cast<long>(j0 + q) * nrow;
        for (int r = r0; r < nrow; ++r) dot[q] += col[r] * u[r];
      }
    } else {
      const double* a[kChunk];
      Pair acc[kChunk];
      for (int q = 0; q < kChunk; ++q) a[q] = block + static_cast<long>(j0 + q) * nrow, acc[q] = Pair{0, 0};
      int r = r0;
      for (; r + 2 <= nrow; r += 2) {
        prefetch_chunk(a, r);
        const Pair z = load_pair(u + r);
        for (int q = 0; q < kChunk; ++q) acc[q] += load_pair(a[q] + r) * z;
      }
      for (int q = 0; q < kChunk; ++q) dot[q] = acc[q][0] + acc[q][1] + (r < nrow ? a[q][r] * u[r] : 0.0);
    }
    for (int c = r0 - 1; c >= j0; --c) {
      const double* col = block + static_cast<long>(c) * nrow;
      double t = u[c] - dot[c - j0];
      for (int r = c + 1; r < r0; ++r) t -= col[r] * u[r];
      u[c] = t / col[c];
    }
  }
}

struct Shape {
  int c0, ncol, nrow, nbelow;
  const double* block;
  const int* rows_below;
};
Shape shape(const SupernodalFactor& f, int k) {
  const int c0 = f.super[k], ncol = f.super[k + 1] - c0, nrow = f.pi[k + 1] - f.pi[k];
  return {c0, ncol, nrow, nrow - ncol, f.x + f.px[k], f.s + f.pi[k] + ncol};
}

// Forward step of supernode k: y_k = L_kk⁻¹ w_k, then w_below −= L_below,k y_k. With
// `top_column`, updates of top rows are added to `top` instead (lane 1). Returns entries skipped.
double forward(const SupernodalFactor& f, int k, double* w, double* u, const unsigned char* top_column,
               double* top) {
  const Shape s = shape(f, k);
  double* y = w + s.c0;
  if (std::all_of(y, y + s.ncol, [](double v) { return v == 0.0; }))  // nothing flows out
    return entries_read(f, k);
  std::copy_n(y, s.ncol, u);
  std::fill_n(u + s.ncol, s.nbelow, 0.0);
  forward_block(s.block, s.nrow, s.ncol, u);
  std::copy_n(u, s.ncol, y);
  const double* t = u + s.ncol;  // −(L_below,k y_k)
  if (top_column == nullptr) {
    for (int i = 0; i < s.nbelow; ++i) w[s.rows_below[i]] += t[i];
  } else {
    for (int i = 0; i < s.nbelow; ++i) {
      const int r = s.rows_below[i];
      if (top_column[r] != 0) top[r] -= t[i];
      else w[r] += t[i];
    }
  }
  return 0;
}

// Back step of supernode k: x_k = L_kk⁻ᵀ (y_k − L_below,kᵀ x_below).
void backward(const SupernodalFactor& f, int k, double* w, double* u) {
  const Shape s = shape(f, k);
  double* y = w + s.c0;
  std::copy_n(y, s.ncol, u);
  for (int i = 0; i < s.nbelow; ++i) u[s.ncol + i] = w[s.rows_below[i]];
  backward_block(s.block, s.nrow, s.ncol, u);
  std::copy_n(u, s.ncol, y);
}
}  // namespace

double entries_read(const SupernodalFactor& f, int k) {
  const double ncol = f.super[k + 1] - f.super[k], nrow = f.pi[k + 1] - f.pi[k];
  return ncol * (ncol + 1) / 2 + ncol * (nrow - ncol);
}

double entries_read(const SupernodalFactor& f) {
  double total = 0;
  for (int k = 0; k < f.nsuper; ++k) total += entries_read(f, k);
  return total;
}

SolvePlan plan_one_lane(const SupernodalFactor& f) {
  SolvePlan plan;
  plan.lanes[0].emplace_back(0, f.nsuper);
  plan.top_column.assign(static_cast<size_t>(f.n), 0);
  return plan;
}

SolvePlan plan_two_lanes(const SupernodalFactor& f) {
  const auto ns = static_cast<size_t>(f.nsuper);
  std::vector<int> col_super(static_cast<size_t>(f.n)), parent(ns, -1), first(ns), count(ns, 1);
  std::vector<double> weight(ns);
  for (int k = 0; k < f.nsuper; ++k)
    for (int c = f.super[k]; c < f.super[k + 1]; ++c) col_super[static_cast<size_t>(c)] = k;
  std::iota(first.begin(), first.end(), 0);
  std::vector<std::vector<int>> children(ns);
  std::vector<int> roots;
  for (int k = 0; k < f.nsuper; ++k) {  // children precede parents: accumulate upwards
    const auto ku = static_cast<size_t>(k);
    weight[ku] += entries_read(f, k);
    const Shape s = shape(f, k);
    if (s.nbelow == 0) {
      roots.push_back(k);
      continue;
    }
    const int p = col_super[static_cast<size_t>(s.rows_below[0])];
    if (p <= k) return plan_one_lane(f);
    const auto pu = static_cast<size_t>(p);
    parent[ku] = p;
    children[pu].push_back(k);
    weight[pu] += weight[ku];
    count[pu] += count[ku];
    first[pu] = std::min(first[pu], first[ku]);
  }
  for (size_t k = 0; k < ns; ++k)  // postordered: every subtree is the range [first, k]
    if (static_cast<size_t>(first[k]) + static_cast<size_t>(count[k]) != k + 1) return plan_one_lane(f);

  // Deal subtrees to two lanes, heaviest first to the lighter lane (LPT); while that is
  // unbalanced, move the heaviest subtree's root to the top and deal its children instead.
  // Keep the deal with the least estimated time, max(lane) + top.
  std::vector<int> dealt = roots, best_dealt;
  std::vector<int> best_owner;
  double top_weight = 0, best_time = 0;
  for (int step = 0; step < 256; ++step) {
    std::sort(dealt.begin(), dealt.end(), [&](int a, int b) { return weight[size_t(a)] > weight[size_t(b)]; });
    std::array<double, 2> load{0, 0};
    std::vector<int> owner(dealt.size());
    for (size_t i = 0; i < dealt.size(); ++i) {
      const int lane = load[1] < load[0] ? 1 : 0;
      owner[i] = lane;
      load[static_cast<size_t>(lane)] += weight[static_cast<size_t>(dealt[i])];
    }
    const double time = std::max(load[0], load[1]) + top_weight;
    if (best_dealt.empty() || time < best_time) best_time = time, best_dealt = dealt, best_owner = owner;
    const int heavy = dealt.front();
    if (children[static_cast<size_t>(heavy)].empty()) break;
    top_weight += entries_read(f, heavy);
    dealt.erase(dealt.begin());
    for (int c : children[static_cast<size_t>(heavy)]) dealt.push_back(c);
  }
  SolvePlan plan;
  plan.top_column.assign(static_cast<size_t>(f.n), 1);
  std::vector<unsigned char> in_lane(ns, 0);
  std::array<double, 2> load{0, 0};
  for (size_t i = 0; i < best_dealt.size(); ++i) {
    const int root = best_dealt[i];
    const auto lane = static_cast<size_t>(best_owner[i]);
    const int begin = first[static_cast<size_t>(root)];
    plan.lanes[lane].emplace_back(begin, root + 1);
    load[lane] += weight[static_cast<size_t>(root)];
    for (int k = begin; k <= root; ++k) {
      in_lane[static_cast<size_t>(k)] = 1;
      for (int c = f.super[k]; c < f.super[k + 1]; ++c) plan.top_column[static_cast<size_t>(c)] = 0;
    }
  }
  for (auto& lane : plan.lanes) std::sort(lane.begin(), lane.end());
  for (int k = 0; k < f.nsuper; ++k)
    if (in_lane[static_cast<size_t>(k)] == 0) plan.top.push_back(k);
  const double total =
      std::accumulate(roots.begin(), roots.end(), 0.0, [&](double a, int r) { return a + weight[size_t(r)]; });
  plan.critical_share = total > 0 ? (std::max(load[0], load[1]) + total - load[0] - load[1]) / total : 1;
  return plan;
}

double solve_supernodal(const SupernodalFactor& f, const SolvePlan& plan, double* w, SolveWorkspace& ws,
                        bool threads) {
  for (auto& b : ws.below) b.resize(static_cast<size_t>(f.n));
  if (ws.lane1_top.size() != static_cast<size_t>(f.n)) ws.lane1_top.assign(static_cast<size_t>(f.n), 0.0);  // kept zero
  std::array<double, 2> skipped{0, 0};
  auto forward_lane = [&](size_t lane) {
    const unsigned char* top_column = lane == 1 ? plan.top_column.data() : nullptr;
    double lane_skipped = 0;  // summed here: the two lanes' counters would share a cache line
    for (const auto& [begin, end] : plan.lanes[lane])
      for (int k = begin; k < end; ++k)
        lane_skipped += forward(f, k, w, ws.below[lane].data(), top_column, ws.lane1_top.data());
    skipped[lane] = lane_skipped;
  };
  auto backward_lane = [&](size_t lane) {
    for (auto r = plan.lanes[lane].rbegin(); r != plan.lanes[lane].rend(); ++r)
      for (int k = r->second; k-- > r->first;) backward(f, k, w, ws.below[lane].data());
  };
  auto both = [&](auto&& pass) {  // one thread: lane 0, then lane 1
    parallel_for(2, threads && !plan.lanes[1].empty() ? 2 : 1, [&](size_t lane) { pass(lane); });
  };
  both(forward_lane);
  for (int k : plan.top)
    for (int c = f.super[k]; c < f.super[k + 1]; ++c) {
      w[c] -= ws.lane1_top[static_cast<size_t>(c)];
      ws.lane1_top[static_cast<size_t>(c)] = 0;
    }
  for (int k : plan.top) skipped[0] += forward(f, k, w, ws.below[0].data(), nullptr, nullptr);
  for (auto k = plan.top.rbegin(); k != plan.top.rend(); ++k) backward(f, *k, w, ws.below[0].data());
  both(backward_lane);
  return skipped[0] + skipped[1];
}

}  // namespace distlab::kelvin
