// CHOLMOD (supernodal, over the system BLAS: OpenBLAS) with reusable solve workspaces.
#include "cholmod_solver.hpp"

#include <cholmod.h>
#include <dlfcn.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <functional>
#include <istream>
#include <mutex>
#include <ostream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "distlab/geometry/parallel.hpp"
#include "elapsed_progress.hpp"
#include "supernodal_solve.hpp"

namespace distlab::kelvin {

namespace {

// OpenBLAS threads help the factorization's large dense blocks but not cholmod_solve2's many
// small triangular and matrix-vector blocks: there, waking and yielding threads cost more than
// they save (seen: 318 ms instead of ~10 ms on a loaded 2-core machine). No-op for another BLAS.
void set_blas_threads(int n) {
  using Fn = void (*)(int);
  static const auto fn = reinterpret_cast<Fn>(::dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  if (fn != nullptr) fn(n);
}

// OpenBLAS's thread count is one setting of the process: every CHOLMOD call that depends on it
// (a factorization on all cores, solves on one) holds this while it runs, so that concurrent
// preparations neither change it under each other's BLAS calls nor leave each other's solves on
// all cores.
class BlasThreads {
 public:
  explicit BlasThreads(int n) : lock_(mutex()) { set_blas_threads(n); }

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  std::lock_guard<std::mutex> lock_;
};

// CHOLMOD 3 (SuiteSparse 5) opens an OpenMP region with a fixed 4 threads inside the supernodal
// factorization for every supernode of more than 128 rows (copying the assembled update): on 2
// shared cores each fork/join wakes and parks threads that have nothing to do (measured at 2.7k
// unknowns: 11 ms CPU per factorization with it, 4.2 ms without, same flops). OpenBLAS's own
// threads, used for the large dense blocks, are not affected. OpenMP runs a region with one
// thread when max-active-levels is 0, so that is set around the factorization and restored.
// No-op without libgomp (the symbols are looked up, as above).
class SerialOpenMP {
 public:
  SerialOpenMP() {
    if (get_ != nullptr && set_ != nullptr) {
      saved_ = get_();
      set_(0);
    }
  }
  ~SerialOpenMP() {
    if (get_ != nullptr && set_ != nullptr) set_(saved_);
  }
  SerialOpenMP(const SerialOpenMP&) = delete;
  SerialOpenMP& operator=(const SerialOpenMP&) = delete;

 private:
  using Get = int (*)();
  using Set = void (*)(int);
  static inline const Get get_ = reinterpret_cast<Get>(::dlsym(RTLD_DEFAULT, "omp_get_max_active_levels"));
  static inline const Set set_ = reinterpret_cast<Set>(::dlsym(RTLD_DEFAULT, "omp_set_max_active_levels"));
  int saved_ = 1;
};

// CHOLMOD's arrays on huge pages like ours (huge_pages.hpp), in the Python module too, whose
// heap is not (the executables' is: app's huge_page_heap.hpp): above all the factor's values,
// which the solves then stream in place (take_values). Set once before main, while nothing
// allocates through it; std::free still releases every block.
[[maybe_unused]] const bool kCholmodOnHugePages = [] {
  SuiteSparse_config.malloc_func = &HugePageAllocator<double>::huge_page_malloc;
  return true;
}();

// Below this many unknowns the factor is ordered by AMD, above by nested dissection (METIS).
// METIS's analysis costs 4–7 µs per unknown against AMD's 0.7 µs, which dominates small
// factorizations. CPU times on a 14-neighbour tetrahedral grid Laplacian, analysis + factor:
// 2.7k unknowns METIS 10.4 + 4.2 ms, AMD 1.9 + 4.8 ms; 22k unknowns METIS 146 + 153 ms, AMD
// 17 + 312 ms. AMD's extra fill (×1.17 at 2.7k, ×1.34 at 8k, ×1.5 at 22k) costs little while
// the factor is small, but from ~20k unknowns nested dissection pays for itself in the
// factorization and in every solve (each reads the factor twice).
constexpr long kNestedDissectionMin = 10000;

// Factors of at least this many entries are solved on two threads (see supernodal_solve.hpp)
// if the two lanes cut the entries read on the critical path to at most kTwoLaneMaxShare: on
// the cube at l_x 0.08 (AMD ordering, 1 thread med 0.71 ms) the top supernodes held 43% of the
// entries, and two threads took 0.77 ms; at 0.06 (METIS, share 0.66) 3.07 against 4.07 ms.
constexpr double kTwoLaneMin = 1e6;
constexpr double kTwoLaneMaxShare = 0.7;

// The numeric factorization's speed in flops (CHOLMOD's count from the analysis) per second, for
// its progress: the last large factorization's in this process, before any the cube's at l_x
// 0.02 in the service (2.05e11 flops in 6.2 s on this 2-core machine, OpenBLAS on both cores).
constexpr double kInitialFlopRate = 3e10;
std::atomic<double>& flop_rate() {
  static std::atomic<double> rate{kInitialFlopRate};
  return rate;
}

}  // namespace

struct CholmodSolver::Impl {
  mutable cholmod_common common;
  cholmod_factor* factor = nullptr;
  mutable cholmod_dense* x = nullptr;  // workspaces reused by cholmod_solve2
  mutable cholmod_dense* y = nullptr;
  mutable cholmod_dense* e = nullptr;
  mutable std::vector<double> work;  // solve(): the permuted vector
  mutable SolveWorkspace workspace;
  SolvePlan plan;
  int solve_threads = std::thread::hardware_concurrency() >= 2 ? 2 : 1;
  mutable double read_fraction = 1;
  double entries_read = 0;  // per pass (supernodal_solve.hpp)
  // The supernodal factor's values in the solve's order (take_values, in CHOLMOD's own array). A
  // caller that needs CHOLMOD's layout again has a copy rebuilt from them (with_cholmod_values).
  SolveValues values;
  mutable std::mutex cholmod_values;
  mutable std::atomic<bool> cholmod_copy{false};  // factor->x is there (read without the lock)
  SupernodalFactor view() const {
    return {static_cast<int>(factor->n), static_cast<int>(factor->nsuper), static_cast<const int*>(factor->super),
            static_cast<const int*>(factor->pi), static_cast<const int*>(factor->px),
            static_cast<const int*>(factor->s), values.values.data(), values.start.data()};
  }
  bool supernodal() const {
    return factor != nullptr && factor->is_super && factor->itype == CHOLMOD_INT && factor->xtype == CHOLMOD_REAL;
  }
  // Drops the factor and everything derived from it: the state after a failed factorize or load.
  void reset() {
    cholmod_free_factor(&factor, &common);
    values = {};
    plan = {};
    entries_read = 0;
    cholmod_copy = false;
  }
  // After a factorization: the values in the solve's order, packed into CHOLMOD's array (which
  // they take over), and the solve plan. A simplicial factor keeps CHOLMOD's values.
  void take_values() {
    cholmod_copy = factor->x != nullptr;
    if (!supernodal() || factor->x == nullptr) return;
    auto* taken = static_cast<double*>(factor->x);
    factor->x = nullptr;  // the values' now (freed with them, or by pack_in_place if it throws)
    cholmod_copy = false;
    values = pack_in_place(view(), taken);
    take_plan();
  }
  void take_plan() {
    plan = plan_two_lanes(view());
    entries_read = kelvin::entries_read(view());
  }
  void free_cholmod_copy() const {
    factor->x = cholmod_free(factor->xsize, sizeof(double), factor->x, &common);
    cholmod_copy = false;
  }
  // Runs fn with CHOLMOD's values in place. `keep`: leave them there afterwards (the reference
  // solve, timed against ours by the benchmarks), else a copy rebuilt for fn is freed again.
  template <class Fn>
  void with_cholmod_values(bool keep, Fn&& fn) const {
    const std::lock_guard<std::mutex> lock(cholmod_values);
    struct Release {
      const Impl* impl;
      bool release = false;
      ~Release() {
        if (release) impl->free_cholmod_copy();
      }
    } release{this};
    if (factor->x == nullptr) {
      factor->x = cholmod_malloc(factor->xsize, sizeof(double), &common);
      if (factor->x == nullptr) throw std::bad_alloc();
      release.release = true;  // freed again if unpacking throws
      unpack_values(view(), static_cast<double*>(factor->x));
      cholmod_copy = true;
      release.release = !keep;
    }
    fn();
  }
  Impl() {
    cholmod_start(&common);
    common.supernodal = CHOLMOD_SUPERNODAL;
    common.print = 0;
    // One ordering, set by size in factorize() (AMD or METIS; see kNestedDissectionMin): on
    // these 3D meshes AMD's factor has about twice the nonzeros at 23k vertices (9.9M against
    // 5.3M), and the solve time is the time to read the factor twice. CHOLMOD's default would
    // try AMD first and keep it unless its fill is very large.
    common.nmethods = 1;
  }
  ~Impl() {
    cholmod_free_dense(&x, &common);
    cholmod_free_dense(&y, &common);
    cholmod_free_dense(&e, &common);
    cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
};

CholmodSolver::CholmodSolver() : impl_(std::make_unique<Impl>()) {}
CholmodSolver::~CholmodSolver() = default;

void CholmodSolver::factorize(const Eigen::SparseMatrix<double>& lower, const std::function<void(double)>& done) {
  cholmod_sparse a{};
  a.nrow = a.ncol = static_cast<size_t>(lower.rows());
  a.nzmax = static_cast<size_t>(lower.nonZeros());
  a.p = const_cast<int*>(lower.outerIndexPtr());
  a.i = const_cast<int*>(lower.innerIndexPtr());
  a.x = const_cast<double*>(lower.valuePtr());
  a.stype = -1;  // lower triangle stored
  a.itype = CHOLMOD_INT;
  a.xtype = CHOLMOD_REAL;
  a.dtype = CHOLMOD_DOUBLE;
  a.sorted = 1;
  a.packed = 1;
  impl_->reset();
  const bool small = lower.rows() < kNestedDissectionMin;
  impl_->common.method[0].ordering = small ? CHOLMOD_AMD : CHOLMOD_METIS;
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  impl_->factor = cholmod_analyze(&a, &impl_->common);
  if (impl_->factor == nullptr) throw std::runtime_error("CHOLMOD analysis failed");
  // The analysis's share of the whole, then the numeric part's estimated from its flop count.
  const double analysed = std::chrono::duration<double>(Clock::now() - t0).count();
  const double flops = impl_->common.fl;
  const double predicted = flops / flop_rate().load(std::memory_order_relaxed);
  const double share = predicted > 0 ? analysed / (analysed + predicted) : 0;
  if (done) done(share);
  // 0: OpenBLAS's default (all cores, or OPENBLAS_NUM_THREADS). Small factors use one thread:
  // their dense blocks are too small to share, and on the loaded 2-core machine waking OpenBLAS's
  // threads made the decomposition 10x slower (bench at l_x 0.1, 3.6k vertices: 0.47 s against
  // 0.040 s with one thread).
  {
    const BlasThreads blas(small ? 1 : 0);
    const SerialOpenMP serial;
    const auto t1 = Clock::now();
    {
      std::function<void(double)> numeric;
      if (done) numeric = [&](double f) { done(share + (1 - share) * f); };
      const ElapsedProgress ticker(numeric, predicted);
      cholmod_factorize(&a, impl_->factor, &impl_->common);
    }
    const double factored = std::chrono::duration<double>(Clock::now() - t1).count();
    if (!small && factored > 0 && flops > 0 && impl_->common.status == CHOLMOD_OK)
      flop_rate().store(flops / factored, std::memory_order_relaxed);
  }
  try {
    if (impl_->common.status == CHOLMOD_NOT_POSDEF)
      throw std::runtime_error("stiffness matrix is not positive definite (degenerate tetrahedra?)");
    if (impl_->common.status < CHOLMOD_OK) throw std::runtime_error("CHOLMOD factorization failed");
    impl_->take_values();
  } catch (...) {
    impl_->reset();  // no factor rather than one without its values ("solve before factorize")
    throw;
  }
}

void CholmodSolver::release_cholmod_values() {
  const std::lock_guard<std::mutex> lock(impl_->cholmod_values);
  if (impl_->supernodal() && impl_->factor->x != nullptr) impl_->free_cholmod_copy();
}

void CholmodSolver::solve(VecX& b) const {
  const cholmod_factor* f = impl_->factor;
  if (f == nullptr || b.size() != size()) throw std::logic_error("solve before factorize");
  if (!impl_->supernodal()) {
    solve_cholmod(b);
    return;
  }
  const bool threads = impl_->solve_threads > 1 && static_cast<double>(f->xsize) >= kTwoLaneMin &&
                       impl_->plan.critical_share <= kTwoLaneMaxShare;
  const double skipped = solve_permuted(b, impl_->work, impl_->workspace, threads);
  const double total = impl_->entries_read;
  impl_->read_fraction = total > 0 ? (2 * total - skipped) / (2 * total) : 1;
}

void CholmodSolver::solve(VecX& b, Scratch& scratch) const {
  const cholmod_factor* f = impl_->factor;
  if (f == nullptr || b.size() != size()) throw std::logic_error("solve before factorize");
  if (!can_solve_alone()) throw std::logic_error("a solve with its own workspace needs the supernodal factor");
  solve_permuted(b, scratch.work, scratch.workspace, false);
}

bool CholmodSolver::can_solve_alone() const { return impl_->supernodal(); }

double CholmodSolver::solve_permuted(VecX& b, std::vector<double>& w, SolveWorkspace& workspace, bool threads) const {
  const cholmod_factor* f = impl_->factor;
  const int* perm = static_cast<const int*>(f->Perm);
  const auto n = static_cast<size_t>(f->n);
  w.resize(n);
  for (size_t k = 0; k < n; ++k) w[k] = b[perm[k]];
  const double skipped = solve_supernodal(impl_->view(), impl_->plan, w.data(), workspace, threads);
  for (size_t k = 0; k < n; ++k) b[perm[k]] = w[k];
  return skipped;
}

void CholmodSolver::set_solve_threads(int threads) { impl_->solve_threads = std::clamp(threads, 1, 2); }

double CholmodSolver::critical_share() const { return impl_->plan.critical_share; }

double CholmodSolver::last_read_fraction() const { return impl_->read_fraction; }

void CholmodSolver::solve_cholmod(VecX& b) const {
  if (impl_->factor == nullptr || b.size() != size()) throw std::logic_error("solve before factorize");
  const BlasThreads blas(1);
  cholmod_dense rhs{};
  rhs.nrow = rhs.d = rhs.nzmax = static_cast<size_t>(b.size());
  rhs.ncol = 1;
  rhs.x = b.data();
  rhs.xtype = CHOLMOD_REAL;
  rhs.dtype = CHOLMOD_DOUBLE;
  impl_->with_cholmod_values(true, [&] {
    if (!cholmod_solve2(CHOLMOD_A, impl_->factor, &rhs, nullptr, &impl_->x, nullptr, &impl_->y, &impl_->e,
                        &impl_->common))
      throw std::runtime_error("CHOLMOD solve failed");
    std::copy_n(static_cast<const double*>(impl_->x->x), b.size(), b.data());
  });
}

namespace {
// cholmod_solve2 of ncol columns at b with its own workspace (common): safe beside other solves.
void solve_block(cholmod_factor* factor, double* b, long ncol) {
  cholmod_common common;
  cholmod_start(&common);
  common.print = 0;
  const auto n = static_cast<size_t>(factor->n);
  cholmod_dense rhs{};
  rhs.nrow = rhs.d = n;
  rhs.ncol = static_cast<size_t>(ncol);
  rhs.nzmax = n * rhs.ncol;
  rhs.x = b;
  rhs.xtype = CHOLMOD_REAL;
  rhs.dtype = CHOLMOD_DOUBLE;
  cholmod_dense *x = nullptr, *y = nullptr, *e = nullptr;
  const bool ok = cholmod_solve2(CHOLMOD_A, factor, &rhs, nullptr, &x, nullptr, &y, &e, &common) != 0;
  if (ok) std::copy_n(static_cast<const double*>(x->x), rhs.nzmax, b);
  cholmod_free_dense(&x, &common);
  cholmod_free_dense(&y, &common);
  cholmod_free_dense(&e, &common);
  cholmod_finish(&common);
  if (!ok) throw std::runtime_error("CHOLMOD solve failed");
}
}  // namespace

void CholmodSolver::solve_columns(double* b, long ncol, long block_columns,
                                  const std::function<void(double)>& after_round) const {
  if (impl_->factor == nullptr) throw std::logic_error("solve before factorize");
  const BlasThreads blas(1);
  const long n = static_cast<long>(impl_->factor->n), blocks = (ncol + block_columns - 1) / block_columns;
  impl_->with_cholmod_values(false, [&] {
    for (long k = 0; k < blocks; k += 2) {
      const long round = std::min<long>(2, blocks - k);
      parallel_for(static_cast<size_t>(round), 2, [&](size_t i) {
        const long c0 = (k + static_cast<long>(i)) * block_columns;
        solve_block(impl_->factor, b + c0 * n, std::min(block_columns, ncol - c0));
      });
      if (after_round) after_round(static_cast<double>(k + round) / static_cast<double>(blocks));
    }
  });
}

double CholmodSolver::solve_megabytes() const {
  const cholmod_factor* f = impl_->factor;
  if (f == nullptr || !f->is_super) return 0;
  const double row_indices = static_cast<double>(static_cast<const int*>(f->pi)[f->nsuper]) - static_cast<double>(f->n);
  return 2 * (8 * impl_->entries_read + 4 * row_indices) / 1e6;
}

Eigen::Index CholmodSolver::size() const {
  return impl_->factor == nullptr ? 0 : static_cast<Eigen::Index>(impl_->factor->n);
}

double CholmodSolver::factor_megabytes() const {
  const cholmod_factor* f = impl_->factor;
  if (f == nullptr) return 0;
  const double values = impl_->cholmod_copy ? static_cast<double>(f->xsize) : 0;  // CHOLMOD's, if there
  return (8.0 * (values + static_cast<double>(impl_->values.values.size())) +
          4.0 * static_cast<double>(f->ssize + 2 * f->n)) /
         1e6;
}

namespace {

template <class T>
void put(std::ostream& out, const T* data, size_t count) {
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(sizeof(T) * count));
}
template <class T>
bool get(std::istream& in, T* data, size_t count) {
  in.read(reinterpret_cast<char*>(data), static_cast<std::streamsize>(sizeof(T) * count));
  return static_cast<bool>(in);
}

}  // namespace

// Layout: sizes, then Perm, ColCount, super, pi, px, s, x (the supernodal LLᵀ factor).
void CholmodSolver::save(std::ostream& out) const {
  const cholmod_factor* f = impl_->factor;
  if (f == nullptr || !f->is_super || f->itype != CHOLMOD_INT) throw std::logic_error("no supernodal factor to save");
  const std::uint64_t sizes[8] = {f->n, f->nsuper, f->ssize, f->xsize, f->maxcsize, f->maxesize,
                                  static_cast<std::uint64_t>(f->ordering), static_cast<std::uint64_t>(f->is_monotonic)};
  put(out, sizes, 8);
  put(out, static_cast<const int*>(f->Perm), f->n);
  put(out, static_cast<const int*>(f->ColCount), f->n);
  put(out, static_cast<const int*>(f->super), f->nsuper + 1);
  put(out, static_cast<const int*>(f->pi), f->nsuper + 1);
  put(out, static_cast<const int*>(f->px), f->nsuper + 1);
  put(out, static_cast<const int*>(f->s), f->ssize);
  // CHOLMOD's layout, one supernode at a time (no second array of the factor's size).
  const SupernodalFactor view = impl_->view();
  const int* px = static_cast<const int*>(f->px);
  std::vector<double> block;
  for (int k = 0; k < view.nsuper; ++k) {
    block.resize(static_cast<size_t>(px[k + 1] - px[k]));
    unpack_supernode(view, k, block.data());
    put(out, block.data(), block.size());
  }
  const std::vector<double> tail(f->xsize - static_cast<size_t>(px[view.nsuper]), 0.0);
  put(out, tail.data(), tail.size());
}

std::uint64_t CholmodSolver::saved_bytes() const {
  const cholmod_factor* f = impl_->factor;
  if (f == nullptr || !f->is_super) return 0;
  return 8 * sizeof(std::uint64_t) + sizeof(int) * (2 * f->n + 3 * (f->nsuper + 1) + f->ssize) + sizeof(double) * f->xsize;
}

bool CholmodSolver::load(std::istream& in) {
  impl_->reset();
  auto read = [&]() -> bool {
    std::uint64_t sizes[8];
    if (!get(in, sizes, 8)) return false;
    const std::uint64_t n = sizes[0], nsuper = sizes[1], ssize = sizes[2], xsize = sizes[3];
    if (n == 0 || n > (1u << 30) || nsuper > n || ssize > (1ull << 34) || xsize > (1ull << 34)) return false;
    cholmod_common* c = &impl_->common;
    cholmod_factor* f = cholmod_allocate_factor(n, c);
    if (f == nullptr) return false;
    // A simplicial symbolic factor with the supernodal sizes set converts to an empty supernodal
    // numeric one of exactly those sizes; then the arrays are filled from the stream.
    f->nsuper = nsuper;
    f->ssize = ssize;
    f->xsize = xsize;
    f->ordering = static_cast<int>(sizes[6]);
    impl_->factor = f;
    if (!get(in, static_cast<int*>(f->Perm), n) || !get(in, static_cast<int*>(f->ColCount), n)) return false;
    if (!cholmod_change_factor(CHOLMOD_REAL, 1, 1, 1, 1, f, c) || !f->is_super) return false;
    // The conversion resets these; the supernodal solve sizes its workspace from maxesize.
    f->maxcsize = sizes[4];
    f->maxesize = sizes[5];
    f->is_monotonic = static_cast<int>(sizes[7]);
    if (!get(in, static_cast<int*>(f->super), nsuper + 1) || !get(in, static_cast<int*>(f->pi), nsuper + 1) ||
        !get(in, static_cast<int*>(f->px), nsuper + 1) || !get(in, static_cast<int*>(f->s), ssize))
      return false;
    // Structural sanity, so a corrupt file cannot send the solver out of bounds.
    const int* super = static_cast<const int*>(f->super);
    const int* pi = static_cast<const int*>(f->pi);
    const int* px = static_cast<const int*>(f->px);
    const int* perm = static_cast<const int*>(f->Perm);
    if (super[0] != 0 || super[nsuper] != static_cast<int>(n) || pi[0] != 0 || px[0] != 0 ||
        static_cast<std::uint64_t>(pi[nsuper]) > ssize || static_cast<std::uint64_t>(px[nsuper]) > xsize)
      return false;
    // Each supernode's rows include its own columns, and its values are its dense rows × columns block.
    // cholmod_solve2 sizes its workspace for the rows below a diagonal block from maxesize.
    for (std::uint64_t k = 0; k < nsuper; ++k) {
      const long ncol = super[k + 1] - super[k], nrow = pi[k + 1] - pi[k];
      if (ncol <= 0 || nrow < ncol || nrow > static_cast<long>(n) - super[k] || px[k + 1] - px[k] != nrow * ncol)
        return false;
      if (static_cast<std::uint64_t>(nrow - ncol) > f->maxesize) return false;
    }
    std::vector<char> seen(n, 0);
    for (std::uint64_t k = 0; k < n; ++k) {
      if (perm[k] < 0 || static_cast<std::uint64_t>(perm[k]) >= n || seen[static_cast<size_t>(perm[k])]) return false;
      seen[static_cast<size_t>(perm[k])] = 1;
    }
    const int* s = static_cast<const int*>(f->s);
    for (std::uint64_t k = 0; k < ssize; ++k)
      if (s[k] < 0 || static_cast<std::uint64_t>(s[k]) >= n) return false;
    // The values are packed into the solve's order as they are read, one supernode at a time:
    // CHOLMOD's copy is not needed after a load (with_cholmod_values rebuilds it on demand).
    impl_->free_cholmod_copy();
    impl_->values = solve_layout(impl_->view());
    std::vector<double> block;
    for (std::uint64_t k = 0; k < nsuper; ++k) {
      block.resize(static_cast<std::size_t>(px[k + 1] - px[k]));
      if (!get(in, block.data(), block.size())) return false;
      pack_supernode(impl_->view(), static_cast<int>(k), block.data(), impl_->values.values.data() + impl_->values.start[k]);
    }
    if (!in.ignore(static_cast<std::streamsize>(sizeof(double) * (xsize - static_cast<std::uint64_t>(px[nsuper]))))) return false;
    impl_->take_plan();
    return true;
  };
  try {
    if (read()) return true;
  } catch (...) {
    impl_->reset();
    throw;
  }
  impl_->reset();  // no factor rather than a half-read one
  return false;
}

}  // namespace distlab::kelvin
