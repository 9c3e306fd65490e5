#include "supernodal_solve.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <numeric>

#include "distlab/geometry/parallel.hpp"

namespace distlab::kelvin {

extern "C" {
// Fortran BLAS (the system's: OpenBLAS, one thread: see cholmod_solver.cpp).
void dtrsv_(const char* uplo, const char* trans, const char* diag, const int* n, const double* a, const int* lda,
            double* x, const int* incx);
void dgemv_(const char* trans, const int* m, const int* n, const double* alpha, const double* a, const int* lda,
            const double* x, const int* incx, const double* beta, double* y, const int* incy);
}

namespace {

// Supernodes of at most this many factor entries are solved by Eigen's inlined kernels, larger
// ones by BLAS: for a small block a BLAS call's fixed cost exceeds its arithmetic.
constexpr long kSmallBlock = 1024;
using Stride = Eigen::OuterStride<>;
using Block = Eigen::Map<const Eigen::MatrixXd, 0, Stride>;
using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1>;

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
double forward(const SupernodalFactor& f, int k, double* w, double* t, const unsigned char* top_column,
               double* top) {
  const Shape s = shape(f, k);
  double* y = w + s.c0;
  if (std::all_of(y, y + s.ncol, [](double v) { return v == 0.0; }))  // nothing flows out
    return static_cast<double>(s.nrow) * s.ncol;
  if (static_cast<long>(s.nrow) * s.ncol <= kSmallBlock) {
    const Block d(s.block, s.ncol, s.ncol, Stride(s.nrow)), l(s.block + s.ncol, s.nbelow, s.ncol, Stride(s.nrow));
    Eigen::Map<Vec> ym(y, s.ncol);
    d.triangularView<Eigen::Lower>().solveInPlace(ym);
    Eigen::Map<Vec>(t, s.nbelow).noalias() = l * ym;
  } else {
    const int one = 1;
    const double p1 = 1, zero = 0;
    dtrsv_("L", "N", "N", &s.ncol, s.block, &s.nrow, y, &one);
    if (s.nbelow == 0) return 0;
    dgemv_("N", &s.nbelow, &s.ncol, &p1, s.block + s.ncol, &s.nrow, y, &one, &zero, t, &one);
  }
  if (top_column == nullptr) {
    for (int i = 0; i < s.nbelow; ++i) w[s.rows_below[i]] -= t[i];
  } else {
    for (int i = 0; i < s.nbelow; ++i) {
      const int r = s.rows_below[i];
      if (top_column[r] != 0) top[r] += t[i];
      else w[r] -= t[i];
    }
  }
  return 0;
}

// Back step of supernode k: x_k = L_kk⁻ᵀ (y_k − L_below,kᵀ x_below).
void backward(const SupernodalFactor& f, int k, double* w, double* t) {
  const Shape s = shape(f, k);
  double* y = w + s.c0;
  for (int i = 0; i < s.nbelow; ++i) t[i] = w[s.rows_below[i]];
  if (static_cast<long>(s.nrow) * s.ncol <= kSmallBlock) {
    const Block d(s.block, s.ncol, s.ncol, Stride(s.nrow)), l(s.block + s.ncol, s.nbelow, s.ncol, Stride(s.nrow));
    Eigen::Map<Vec> ym(y, s.ncol);
    ym.noalias() -= l.transpose() * Eigen::Map<const Vec>(t, s.nbelow);
    d.transpose().triangularView<Eigen::Upper>().solveInPlace(ym);
    return;
  }
  const int one = 1;
  const double p1 = 1, m1 = -1;
  if (s.nbelow > 0) dgemv_("T", &s.nbelow, &s.ncol, &m1, s.block + s.ncol, &s.nrow, t, &one, &p1, y, &one);
  dtrsv_("L", "T", "N", &s.ncol, s.block, &s.nrow, y, &one);
}

double entries(const SupernodalFactor& f, int k) {
  return static_cast<double>(f.pi[k + 1] - f.pi[k]) * (f.super[k + 1] - f.super[k]);
}

}  // namespace

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
    weight[ku] += entries(f, k);
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
    top_weight += entries(f, heavy);
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
