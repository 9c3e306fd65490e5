// distlab-bench-kelvin: Table I (cube) and Table II (wrench) of the Kelvin paper, with Eigen's
// SparseLU (the paper's solver) and CGAL's AABB-tree distance in the same run.
// usage: distlab-bench-kelvin [--assets DIR] [--lx 0.2,0.15,...] [--grid 1000] [--lu-max 60000]
//                             [--wrench-lx 0.002] [--wrench-features 180] [--json FILE]
//                             [--table2-only 1] [--table1-only 1] [--sphere-rmse 0.1,0.05,...]
//                             [--cache-dir DIR] [--far-radius 1] [--grading 0 or auto] [--mesh-worker EXE]
//                             [--sizing-table 0.05,0.03 [--gradings 0,0.3]]
// --cache-dir reuses prepared objects (Field::prepare_cached): t_mesh and t_decomp are then those
// of the original preparation, t_build is measured again.
// t_solve is σ → V (eqs. 17, 20, 21: what the paper times; mean and median of 100); t_grad, the
// vertex gradients for ∇h, is reported beside it; "1 thread med" is the σ solve on one thread
// (blocks of 10 alternating with two threads). "own dense" and chol_ms: the same factor's
// solve with a dense right-hand side (all ones) by our supernodal solve and by CHOLMOD's
// cholmod_solve2; LU_*: Eigen SparseLU on the same matrix and right-hand side. The bandwidth
// table sets the dense solve's bytes per second against a read stream measured in the same run.
// The SparseLU comparison (decomp med, LU_decomp; solve b, LU_solve) is made in the run itself,
// both sides the same way: see compare_with_sparselu.
#include <Eigen/SparseLU>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <unistd.h>
#include <nlohmann/json.hpp>

#include "../src/huge_page_heap.hpp"
#include "cholmod_solver.hpp"  // private to distlab_kelvin: the factorization Field::prepare runs
#include "distlab/geometry/parallel.hpp"
#include "distlab/kelvin/digest.hpp"
#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/isolated_mesher.hpp"
#include "distlab/kelvin/surface_tools.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/surface.hpp"
#include "distlab/mesh/weld.hpp"
#include "load_average.hpp"
#include "query_sets.hpp"

using namespace distlab;
using namespace distlab::kelvin;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Per-query timings in µs: a coherent path with the previous cell as hint, and random points
// located through the seeding grid.
double percentile(std::vector<double> v, double q) {
  const auto k = static_cast<long>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<size_t>(k)];
}

// Memory bandwidth of this machine, in GB/s, the best of 5 passes split between `threads`
// threads, on arrays of 256 MB each (≫ cache): "read" sums one array (as a triangular solve
// streams its factor), "copy" b = a and "triad" a = b + 3 c as STREAM counts them (bytes read
// and written, 16 and 24 per element).
struct Stream {
  double read = 0, copy = 0, triad = 0;
  double read_cpu = 0;  // one thread: "read" by process CPU time, median of the 5 (as the solve's CPU column)
};
// Σ p[0 … n): eight independent sums, so that the loop is bound by memory, not by add latency.
double read_sum(const double* p, size_t n) {
  double acc[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  for (size_t i = 0; i + 8 <= n; i += 8)
    for (int k = 0; k < 8; ++k) acc[k] += p[i + static_cast<size_t>(k)];
  return acc[0] + acc[1] + acc[2] + acc[3] + acc[4] + acc[5] + acc[6] + acc[7];
}

// One pass of the one-thread stream read over 256 MB, GB/s: taken right after each timed solve,
// so that solve and stream share the moment's load (bandwidth_pairs).
double read_pass_gbps() {
  static const std::vector<double> a(std::size_t{32} << 20, 1.0);
  const auto t0 = Clock::now();
  const double sum = read_sum(a.data(), a.size());
  const double s = since(t0);
  if (sum != static_cast<double>(a.size())) throw std::runtime_error("stream: wrong sum");
  return 8.0 * static_cast<double>(a.size()) / s / 1e9;
}

Stream stream_gbps(int threads) {
  static std::vector<double> a(std::size_t{32} << 20, 1.0), b(a.size(), 2.0), c(a.size(), 0.5);
  const size_t chunk = a.size() / static_cast<size_t>(threads);
  std::vector<double> sums(static_cast<size_t>(threads));
  auto best_of = [&](double bytes_per_element, auto&& kernel) {
    double best = 0;
    for (int rep = 0; rep < 5; ++rep) {
      const auto t0 = Clock::now();
      parallel_for(static_cast<size_t>(threads), static_cast<unsigned>(threads), [&](size_t t) { kernel(t * chunk, t); });
      best = std::max(best, bytes_per_element * static_cast<double>(chunk) * threads / since(t0) / 1e9);
    }
    return best;
  };
  Stream s;
  std::vector<double> cpu;
  auto read_kernel = [&](size_t begin, size_t t) { sums[t] = read_sum(a.data() + begin, chunk); };
  s.read = best_of(8, [&](size_t begin, size_t t) {
    const std::clock_t c0 = std::clock();
    read_kernel(begin, t);
    if (threads == 1) cpu.push_back(static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
  });
  if (threads == 1) s.read_cpu = 8.0 * static_cast<double>(chunk) / median(cpu) / 1e9;
  double total = 0;
  for (double v : sums) total += v;
  if (total != static_cast<double>(chunk) * threads) throw std::runtime_error("stream: wrong sum");
  s.copy = best_of(16, [&](size_t begin, size_t) { std::copy_n(a.data() + begin, chunk, b.data() + begin); });
  s.triad = best_of(24, [&](size_t begin, size_t) {
    for (size_t i = begin; i < begin + chunk; ++i) c[i] = b[i] + 3.0 * a[i];
  });
  if (c[0] != 4.0 || c[threads * chunk - 1] != 4.0) throw std::runtime_error("stream: wrong triad");  // b = a = 1 after copy
  return s;
}

std::tuple<double, double, double> query_times(const Field& f, const std::vector<Vec3>& path, const std::vector<Vec3>& random) {
  std::vector<double> hinted, seeded;
  int hint = -1;
  double sink = 0;
  for (const Vec3& x : path) {
    const auto t0 = Clock::now();
    sink += f.query(x, &hint).h;
    hinted.push_back(since(t0) * 1e6);
  }
  for (const Vec3& x : random) {
    const auto t0 = Clock::now();
    sink += f.query(x).h;
    seeded.push_back(since(t0) * 1e6);
  }
  if (sink == 12345.678) std::puts("");  // keep the queries observable
  return {median(hinted), median(seeded), percentile(seeded, 0.9)};
}

struct Row {
  double lx = 0;
  Stats stats;
  double solve_ms = 0, solve_med = 0, solve_1t_med = 0, solve_sd = 0, grad_ms = 0, chol_solve_ms = 0, dense_solve_ms = 0, q_seed_p90 = 0, rmse = -1, q_hint = 0, q_seed = 0;
  double dense_1t_ms = 0;      // "own dense" on one thread
  double dense_1t_cpu_ms = 0;  // the same, process CPU time (the machine is shared: wall time includes waiting)
  // Each one-thread solve against a stream read pass right after it: medians of the pass's GB/s
  // and of the solve's share of it.
  double paired_stream_gbps = 0, paired_share = 0;
  std::vector<double> case_solve_ms;  // Table II: one per σ case
  double lu_decomp = -1, lu_solve_ms = -1, aabb_us = 0;
  double decomp_med = -1, solve_b_ms = -1;           // CHOLMOD's side of the SparseLU comparison
  double solve_ones_ms = -1, lu_solve_ones_ms = -1;  // the same with b = 1
  // A local σ edit by linearity (see compare_with_sparselu): the stroke's solve and the share of
  // the factor each solve reads.
  double stroke_ms = -1, stroke_read = -1, full_read = -1;
  // The same stroke through Field::set_sigma (t_solve, medians), against its full solve: with the
  // factor, and with the boundary response (its MB and build time); boundary values changed.
  double field_full_ms = -1, field_stroke_ms = -1, response_full_ms = -1, response_stroke_ms = -1;
  double response_mb = 0, response_build_s = 0;
  long stroke_boundary = 0, n_boundary = 0;
  int decomp_reps = 0, solve_reps = 0;
};

// The right-hand side of eq. 20 for the σ last set, b = −A_Ω∂ V_∂, from Field's public data:
// its interior vertices in its order (used by a domain cell, on no boundary face; ascending), and
// b = A_ΩΩ x with x their values, exactly 0 where the vertex shares no cell with the boundary
// (as −A_Ω∂ V_∂ is). Checked by the caller: solving it gives x back.
// positions (if given): each interior vertex mapped back to x (eq. 5).
VecX eq20_rhs(const Field& f, const Eigen::SparseMatrix<double>& a, VecX& x, std::vector<Vec3>* positions = nullptr) {
  const TetMesh& m = f.tet_mesh();
  const auto np = static_cast<size_t>(m.points.rows());
  std::vector<char> used(np, 0), on_boundary(np, 0);
  for (Eigen::Index c = 0; c < m.tets.rows(); ++c) {
    if (!m.in_domain[static_cast<size_t>(c)]) continue;
    for (int k = 0; k < 4; ++k) {
      used[static_cast<size_t>(m.tets(c, k))] = 1;
      const int n = m.neighbours(c, k);
      if (n < 0 || !m.in_domain[static_cast<size_t>(n)])
        for (int j = 0; j < 4; ++j)
          if (j != k) on_boundary[static_cast<size_t>(m.tets(c, j))] = 1;
    }
  }
  std::vector<long> slot(np, -1);
  std::vector<size_t> interior;
  for (size_t v = 0; v < np; ++v)
    if (used[v] && !on_boundary[v]) slot[v] = static_cast<long>(interior.size()), interior.push_back(v);
  if (static_cast<Eigen::Index>(interior.size()) != a.rows()) throw std::runtime_error("interior vertices do not match A_OO");
  std::vector<char> touches(interior.size(), 0);
  for (Eigen::Index c = 0; c < m.tets.rows(); ++c) {
    if (!m.in_domain[static_cast<size_t>(c)]) continue;
    bool bnd = false;
    for (int k = 0; k < 4; ++k) bnd = bnd || on_boundary[static_cast<size_t>(m.tets(c, k))];
    for (int k = 0; k < 4 && bnd; ++k)
      if (const long s = slot[static_cast<size_t>(m.tets(c, k))]; s >= 0) touches[static_cast<size_t>(s)] = 1;
  }
  x.resize(a.rows());
  for (size_t i = 0; i < interior.size(); ++i) x[static_cast<Eigen::Index>(i)] = f.vertex_values()[static_cast<Eigen::Index>(interior[i])];
  VecX b = a * x;
  for (size_t i = 0; i < interior.size(); ++i)
    if (!touches[i]) b[static_cast<Eigen::Index>(i)] = 0;
  if (positions)
    for (size_t v : interior) {
      const Vec3 y = m.points.row(static_cast<Eigen::Index>(v));
      positions->push_back(f.centre() + y / y.squaredNorm());
    }
  return b;
}

// Eigen SparseLU (the paper's solver) against CHOLMOD through CholmodSolver (the code
// Field::prepare and set_sigma run) on the same matrix A_ΩΩ and the same right-hand side, timed
// the same way. Right-hand sides: eq. 20's for the σ last set (what t_solve solves; zero away
// from the boundary, which CholmodSolver's forward pass skips), and b = 1 (dense). Decomposition: every repeat builds a fresh one on both sides, fill-reducing
// ordering included (cholmod_analyze + cholmod_factorize; SparseLU::compute = analyzePattern with
// COLAMD + factorize), the sides alternating which goes first. Solve: blocks of 5 solves b → x on
// one side then on the other (each on its own warm factor, as repeated σ → V solves run), the
// blocks alternating which side goes first. The medians of the repeats are compared (a single
// run of ~100 µs is noise on a shared machine). Repeats: as many as fit in about half a second
// per step, at least 5 decompositions and 25 solves per side, at most 31 and 205.
void compare_with_sparselu(const Field& f, Row& r) {
  const Eigen::SparseMatrix<double> a = f.reduced_matrix();
  const Eigen::SparseMatrix<double> lower = a.triangularView<Eigen::Lower>();
  VecX x20;
  std::vector<Vec3> at;
  const VecX b20 = eq20_rhs(f, a, x20, &at), ones = VecX::Ones(a.rows());
  // A brush stroke over 5% of the surface changes V_∂ there only; by linearity the change of V
  // solves A_ΩΩ ΔV = −A_Ω∂ ΔV_∂, nonzero in the rows of b20 next to the stroke: the 5% of b20's
  // nonzero rows nearest (in x) to one of them. Its forward pass skips every supernode off their
  // elimination-tree paths; the back pass reads the whole factor (ΔV, harmonic, is nonzero
  // everywhere), so such a solve reads at least half of what a full one reads.
  VecX stroke = VecX::Zero(a.rows());
  {
    std::vector<std::pair<double, Eigen::Index>> rows;
    Eigen::Index first = -1;
    for (Eigen::Index i = 0; i < b20.size(); ++i)
      if (b20[i] != 0) {
        if (first < 0) first = i;
        rows.emplace_back((at[static_cast<size_t>(i)] - at[static_cast<size_t>(first)]).norm(), i);
      }
    std::sort(rows.begin(), rows.end());
    for (size_t k = 0; k < (rows.size() + 19) / 20; ++k) stroke[rows[k].second] = b20[rows[k].second];
  }
  CholmodSolver chol;
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
  std::vector<double> tc, tl;
  auto decompose = [&](bool cholmod_first) {
    for (int side = 0; side < 2; ++side) {
      const auto t0 = Clock::now();
      if ((side == 0) == cholmod_first) {
        CholmodSolver fresh;
        fresh.factorize(lower);
        tc.push_back(since(t0));
        if (tc.size() == 1) chol.factorize(lower);  // kept for the solves (same factor)
      } else {
        Eigen::SparseLU<Eigen::SparseMatrix<double>> fresh;
        fresh.compute(a);
        tl.push_back(since(t0));
        if (fresh.info() != Eigen::Success) throw std::runtime_error("SparseLU failed on A_OO");
      }
    }
  };
  decompose(true);
  lu.compute(a);
  const int decomp_reps = std::clamp(static_cast<int>(0.5 / (tc[0] + tl[0])), 5, 31) | 1;
  for (int i = 1; i < decomp_reps; ++i) decompose(i % 2 == 0);
  std::vector<double> sc, sl, sc1, sl1;
  double diff = 0;
  // A block of kBlock solves of one b on one side, then on the other: each side solves on its
  // own warm factor, as in repeated σ → V solves.
  constexpr int kBlock = 5;
  auto solve = [&](const VecX& b, bool cholmod_first, std::vector<double>& c, std::vector<double>& l) {
    VecX x, y;
    for (int side = 0; side < 2; ++side)
      for (int k = 0; k < kBlock; ++k) {
        const auto t0 = Clock::now();
        if ((side == 0) == cholmod_first) {
          x = b;
          chol.solve(x);
          c.push_back(since(t0) * 1e3);
        } else {
          y = lu.solve(b);
          l.push_back(since(t0) * 1e3);
        }
      }
    diff = std::max(diff, (x - y).norm() / y.norm());
    return x;
  };
  const VecX x = solve(b20, true, sc, sl);
  diff = std::max(diff, (x - x20).norm() / x20.norm());  // eq. 20's b solves to the field's values
  solve(ones, true, sc1, sl1);
  std::vector<double> ss;  // the stroke's solve, in the blocks of eq. 20's
  VecX w;
  auto stroke_solve = [&] {
    for (int k = 0; k < kBlock; ++k) {
      w = stroke;
      const auto t0 = Clock::now();
      chol.solve(w);
      ss.push_back(since(t0) * 1e3);
    }
    r.stroke_read = chol.last_read_fraction();
    w = b20;
    chol.solve(w);
    r.full_read = chol.last_read_fraction();
  };
  stroke_solve();
  const int solve_blocks = std::clamp(static_cast<int>(0.25e3 / (median(sc) + median(sl)) / kBlock), 5, 41) | 1;
  for (int i = 1; i < solve_blocks; ++i) {
    solve(b20, i % 2 == 0, sc, sl);
    solve(ones, i % 2 == 1, sc1, sl1);
    stroke_solve();
  }
  r.stroke_ms = median(ss);
  const int solve_reps = solve_blocks * kBlock;
  if (diff > 1e-9) throw std::runtime_error("SparseLU, CHOLMOD and the field disagree on A_OO x = b");
  r.solve_ones_ms = median(sc1);
  r.lu_solve_ones_ms = median(sl1);
  r.decomp_med = median(tc);
  r.lu_decomp = median(tl);
  r.solve_b_ms = median(sc);
  r.lu_solve_ms = median(sl);
  r.decomp_reps = decomp_reps;
  r.solve_reps = solve_reps;
}

// A brush stroke through Field::set_sigma: one stamp on the 5% of the boundary vertices nearest
// to one of them, added to `base`. Blocks of a full solve of `base` then the stroke (by
// linearity), with the factor; then the boundary response is built and the same again. The
// stroke's V by the response must equal the one by the factor to 1e-12.
void measure_strokes(Field& f, const SigmaSpec& base, Row& r) {
  const std::vector<Vec3> at = f.boundary_points();
  std::vector<double> d(at.size());
  std::transform(at.begin(), at.end(), d.begin(), [&](const Vec3& x) { return (x - at.front()).norm(); });
  std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 20), d.end());
  SigmaSpec stroke = base;
  stroke.brushes.push_back({at.front(), d[d.size() / 20], 0.5, 0, false});
  r.n_boundary = static_cast<long>(at.size());
  auto blocks = [&](double& full_ms, double& stroke_ms, bool by_response) {
    std::vector<double> full, strokes;
    for (int i = 0; i < 41; ++i) {
      f.set_sigma(base, false, false);
      full.push_back(f.stats().t_solve * 1e3);
      f.set_sigma(stroke, false);
      if (f.stats().linear_by_response != by_response || f.stats().linear_boundary < 0)
        throw std::runtime_error("the stroke did not take the path measured");
      strokes.push_back(f.stats().t_solve * 1e3);
    }
    r.stroke_boundary = f.stats().linear_boundary;
    full_ms = median(full);
    stroke_ms = median(strokes);
    return f.vertex_values();
  };
  const VecX by_factor = blocks(r.field_full_ms, r.field_stroke_ms, false);
  const auto t0 = Clock::now();
  if (!f.build_boundary_response(1e9)) throw std::runtime_error("the boundary response was not built");
  r.response_build_s = since(t0);
  r.response_mb = f.stats().response_mb;
  const VecX by_response = blocks(r.response_full_ms, r.response_stroke_ms, true);
  f.release_boundary_response();
  double diff = 0, scale = 0;
  for (Eigen::Index v = 0; v < by_factor.size(); ++v)
    if (!std::isnan(by_factor[v]))
      diff = std::max(diff, std::abs(by_response[v] - by_factor[v])), scale = std::max(scale, std::abs(by_factor[v]));
  if (diff > 1e-12 * scale) throw std::runtime_error("the stroke by the boundary response differs from its solve");
}

nlohmann::json to_json(const Row& r) {
  return {{"lx", r.lx}, {"n_verts", r.stats.n_verts}, {"n_tets", r.stats.n_tets}, {"size_mb", r.stats.size_mb}, {"rmse", r.rmse}, {"t_mesh", r.stats.t_mesh}, {"t_build", r.stats.t_build}, {"t_decomp", r.stats.t_decomp}, {"grading", r.stats.grading}, {"mesh_threads", r.stats.mesh_threads}, {"t_solve_ms", r.solve_ms}, {"t_solve_sd_ms", r.solve_sd}, {"t_grad_ms", r.grad_ms}, {"t_solve_median_ms", r.solve_med}, {"t_solve_one_thread_median_ms", r.solve_1t_med}, {"t_cholmod_solve_ms", r.chol_solve_ms}, {"t_own_dense_solve_ms", r.dense_solve_ms}, {"t_query_nohint_p90_us", r.q_seed_p90}, {"t_solve_cases_ms", r.case_solve_ms}, {"t_query_hint_us", r.q_hint}, {"t_query_nohint_us", r.q_seed}, {"t_sparselu_decomp", r.lu_decomp}, {"t_sparselu_solve_ms", r.lu_solve_ms}, {"t_aabb_distance_us", r.aabb_us}, {"t_decomp_median", r.decomp_med}, {"t_solve_b_ms", r.solve_b_ms}, {"t_solve_ones_ms", r.solve_ones_ms}, {"t_sparselu_solve_ones_ms", r.lu_solve_ones_ms}, {"sparselu_decomp_repeats", r.decomp_reps}, {"sparselu_solve_repeats", r.solve_reps}, {"factor_mb", r.stats.factor_mb}, {"t_own_dense_solve_one_thread_ms", r.dense_1t_ms}, {"t_own_dense_solve_one_thread_cpu_ms", r.dense_1t_cpu_ms}, {"t_stroke_solve_ms", r.stroke_ms}, {"stroke_read_fraction", r.stroke_read}, {"full_read_fraction", r.full_read}, {"t_set_sigma_full_ms", r.field_full_ms}, {"t_set_sigma_stroke_ms", r.field_stroke_ms}, {"t_set_sigma_full_beside_response_ms", r.response_full_ms}, {"t_set_sigma_stroke_by_response_ms", r.response_stroke_ms}, {"response_mb", r.response_mb}, {"t_response_build", r.response_build_s}, {"stroke_boundary_values", r.stroke_boundary}, {"n_boundary", r.n_boundary}};
}

Row run(const mesh::SurfaceMesh& surface, const PrepareOptions& o, const std::vector<SigmaSpec>& sigmas,
        const std::vector<Vec3>& path, const std::vector<Vec3>& random, long lu_max,
        const std::string& cache_dir, std::optional<Field>* keep = nullptr) {
  Field f = cache_dir.empty() ? Field::prepare(surface, o) : Field::prepare_cached(surface, o, cache_dir);
  Row r;
  r.lx = o.lx;
  std::vector<double> t;
  for (const SigmaSpec& sigma : sigmas) {  // 100 solves per case; the first case fills t
    std::vector<double> tc;
    for (int i = 0; i < 100; ++i) {
      f.set_sigma(sigma, false, false);  // the full solve every time (the paper's t_solve)
      tc.push_back(f.stats().t_solve * 1e3);
    }
    double m = 0;
    for (double v : tc) m += v / tc.size();
    r.case_solve_ms.push_back(m);
    if (t.empty()) t = tc;
  }
  for (int i = 0; i < 10; ++i) {
    f.set_sigma(sigmas.front(), true, false);
    r.grad_ms += f.stats().t_gradient * 1e3 / 10;
  }
  double mean = 0, sq = 0;
  for (double v : t) mean += v / t.size();
  for (double v : t) sq += (v - mean) * (v - mean) / t.size();
  r.solve_ms = mean;
  r.solve_med = median(t);
  r.solve_sd = std::sqrt(sq);
  {  // The same σ solve on one thread, in blocks alternating with the default (two on 2+ cores).
    std::vector<double> one;
    for (int block = 0; block < 10; ++block)
      for (int threads : {1, 2})
        for (int i = 0; i < 10; ++i) {
          f.set_solve_threads(threads);
          f.set_sigma(sigmas.front(), false, false);
          if (threads == 1) one.push_back(f.stats().t_solve * 1e3);
        }
    f.set_solve_threads(2);
    r.solve_1t_med = median(one);
  }
  r.stats = f.stats();
  const Eigen::SparseMatrix<double> a = f.reduced_matrix();
  const VecX b = VecX::Ones(a.rows());
  {
    std::vector<double> ts, tc, t1, c1, stream, share;
    for (int i = 0; i < 20; ++i) {
      VecX x = b, y = b, z = b;
      auto t0 = Clock::now();
      f.solve_reduced(x);
      ts.push_back(since(t0) * 1e3);
      t0 = Clock::now();
      f.solve_reduced(y, true);
      tc.push_back(since(t0) * 1e3);
      f.set_solve_threads(1);
      t0 = Clock::now();
      const std::clock_t cpu0 = std::clock();
      f.solve_reduced(z);
      c1.push_back(1e3 * static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC);
      t1.push_back(since(t0) * 1e3);
      f.set_solve_threads(2);
      stream.push_back(read_pass_gbps());
      share.push_back(r.stats.solve_read_mb / t1.back() / stream.back());  // MB/ms = GB/s
    }
    r.paired_stream_gbps = median(stream);
    r.paired_share = median(share);
    r.dense_solve_ms = median(ts);
    r.chol_solve_ms = median(tc);
    r.dense_1t_ms = median(t1);
    r.dense_1t_cpu_ms = median(c1);
  }
  if (r.stats.n_verts <= lu_max) {
    compare_with_sparselu(f, r);
    measure_strokes(f, sigmas.front(), r);
  }
  std::tie(r.q_hint, r.q_seed, r.q_seed_p90) = query_times(f, path, random);
  const SurfaceOracle oracle(surface);
  std::vector<double> ts;
  double sink = 0;
  for (const Vec3& x : random) {
    const auto t0 = Clock::now();
    sink += oracle.distance(x);
    ts.push_back(since(t0) * 1e6);
  }
  if (sink < 0) std::puts("");
  r.aabb_us = median(ts);
  if (keep) keep->emplace(std::move(f));
  return r;
}

void print(const char* title, const std::vector<Row>& rows) {
  std::printf(
      "\n%s\n| l_x | N_verts | N_tets | MB | RMSE | t_mesh | t_build | t_decomp | t_solve | t_solve med | 1 thread med | t_grad | "
      "own dense | chol_ms | q_hint | q_seed | q_seed p90 | decomp med | LU_decomp | solve b | LU_solve | AABB |\n|%s\n",
      title,
      "---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
  for (const Row& r : rows)
    std::printf("| %.3g | %ld | %ld | %.2f | %.4f | %.2f | %.3f | %.3f | %.2f ± %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.3f | %.3f | %.3f | %.3g | %.3g | %.3g | %.3g | %.3f |\n",
                r.lx, r.stats.n_verts, r.stats.n_tets, r.stats.size_mb, r.rmse, r.stats.t_mesh, r.stats.t_build,
                r.stats.t_decomp, r.solve_ms, r.solve_sd, r.solve_med, r.solve_1t_med, r.grad_ms, r.dense_solve_ms, r.chol_solve_ms,
                r.q_hint, r.q_seed, r.q_seed_p90, r.decomp_med, r.lu_decomp, r.solve_b_ms, r.lu_solve_ms, r.aabb_us);
  // The comparison's convention, and its ratios (issue 3 targets: decomposition ≥ 10×, solve ≥ 3×).
  std::printf(
      "SparseLU comparison (same A_ΩΩ, same b, both timed the same way, sides alternating; medians): "
      "decomp med / LU_decomp = one fresh decomposition, fill-reducing ordering included in both "
      "(cholmod_analyze + factorize; analyzePattern with COLAMD + factorize), in s; solve b / LU_solve = "
      "one solve of A_ΩΩ x = b with eq. 20's b (as t_solve), in ms; also with b = 1. t_decomp is the "
      "preparation's single run (or the cached one's).\n");
  for (const Row& r : rows)
    if (r.lu_decomp > 0 && r.decomp_med > 0)
      std::printf(
          "l_x %.3g: LU_decomp / decomp med = %.1f (%d repeats), LU_solve / solve b = %.1f (b = 1: %.4f / %.4f ms "
          "= %.1f; %d repeats)\n",
          r.lx, r.lu_decomp / r.decomp_med, r.decomp_reps, r.lu_solve_ms / r.solve_b_ms,
          r.lu_solve_ones_ms, r.solve_ones_ms, r.lu_solve_ones_ms / r.solve_ones_ms, r.solve_reps);
  std::fflush(stdout);
}

// A dense solve (b = 1) reads the factor twice (forward and back substitution): its achieved
// bandwidth is the bytes it reads (Stats::solve_read_mb: the lower triangle of each diagonal
// block, the panel below and its row indices; not the few stored entries it streams without
// needing them, supernodal_solve.hpp) over its time, set
// against this machine's stream measured in the same run (read: the solve's own access; triad:
// STREAM's figure). The one-thread solve also by CPU time: on the shared machine the wall time
// includes waiting for a core, the stream (best of 5) catches a quiet moment. "Paired": each of
// the 20 one-thread solves against a stream read pass right after it, the median of the 20
// ratios, so that both see the same moment's load from the machine's other tenants.
nlohmann::json print_bandwidth(const std::vector<Row>& rows, const Stream& s1, const Stream& s2) {
  std::printf(
      "\nTriangular solves against memory bandwidth (arrays of 256 MB, best of 5; GB/s read / copy / triad: "
      "1 thread %.2f / %.2f / %.2f, 2 threads %.2f / %.2f / %.2f; 1 thread read by CPU time, median: %.2f)\n| l_x | N_verts | factor MB | read MB per solve | "
      "dense 1 thread ms | GB/s | of read | of triad | CPU ms | GB/s by CPU time | of read | dense 2 threads ms | GB/s | "
      "of read | of triad | paired stream GB/s | paired: of read |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
      s1.read, s1.copy, s1.triad, s2.read, s2.copy, s2.triad, s1.read_cpu);
  nlohmann::json out;
  for (const Row& r : rows) {
    const double gb = r.stats.solve_read_mb / 1e3, bw1 = gb / (r.dense_1t_ms / 1e3), bw2 = gb / (r.dense_solve_ms / 1e3),
                 bwc = gb / (r.dense_1t_cpu_ms / 1e3);
    std::printf("| %.3g | %ld | %.1f | %.1f | %.2f | %.2f | %.0f%% | %.0f%% | %.2f | %.2f | %.0f%% | %.2f | %.2f | %.0f%% | %.0f%% | %.2f | %.0f%% |\n",
                r.lx, r.stats.n_verts, r.stats.factor_mb, r.stats.solve_read_mb, r.dense_1t_ms, bw1, 100 * bw1 / s1.read,
                100 * bw1 / s1.triad, r.dense_1t_cpu_ms, bwc, 100 * bwc / s1.read_cpu, r.dense_solve_ms, bw2, 100 * bw2 / s2.read,
                100 * bw2 / s2.triad, r.paired_stream_gbps, 100 * r.paired_share);
    out.push_back({{"lx", r.lx}, {"factor_mb", r.stats.factor_mb}, {"solve_read_mb", r.stats.solve_read_mb}, {"solve_gbps_one_thread", bw1}, {"solve_gbps_one_thread_cpu", bwc}, {"solve_gbps_two_threads", bw2}, {"stream_gbps_one_thread", s1.read}, {"stream_gbps_one_thread_cpu", s1.read_cpu}, {"stream_gbps_two_threads", s2.read}, {"stream_copy_gbps_one_thread", s1.copy}, {"stream_copy_gbps_two_threads", s2.copy}, {"stream_triad_gbps_one_thread", s1.triad}, {"stream_triad_gbps_two_threads", s2.triad}, {"paired_stream_gbps_one_thread", r.paired_stream_gbps}, {"paired_share_of_read_one_thread", r.paired_share}});
  }
  std::printf(
      "\nLocal σ edit by linearity (a stroke over 5%% of the surface; same factor, medians): the stroke's "
      "solve against eq. 20's full one, and the share of the factor's entries each reads\n| l_x | N_verts | full "
      "solve b ms | stroke solve ms | ratio | full reads | stroke reads |\n|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows)
    if (r.stroke_ms > 0)
      std::printf("| %.3g | %ld | %.3f | %.3f | %.2f | %.3f | %.3f |\n", r.lx, r.stats.n_verts, r.solve_b_ms, r.stroke_ms,
                  r.stroke_ms / r.solve_b_ms, r.full_read, r.stroke_read);
  std::printf(
      "\nThe same stroke through Field::set_sigma (t_solve, medians of 41 full solves alternating with 41 "
      "strokes): by the factor, then with the boundary response (field.hpp); each ratio against the full "
      "solves of its own blocks\n| l_x | N_verts | boundary values changed | full ms | stroke by factor ms | ratio | "
      "full ms | stroke by response ms | ratio | response MB | factor MB | response build s |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows)
    if (r.response_stroke_ms > 0)
      std::printf("| %.3g | %ld | %ld of %ld | %.3f | %.3f | %.2f | %.3f | %.3f | %.2f | %.0f | %.0f | %.2f |\n", r.lx,
                  r.stats.n_verts, r.stroke_boundary, r.n_boundary, r.field_full_ms, r.field_stroke_ms,
                  r.field_stroke_ms / r.field_full_ms, r.response_full_ms, r.response_stroke_ms,
                  r.response_stroke_ms / r.response_full_ms, r.response_mb, r.stats.factor_mb, r.response_build_s);
  std::fflush(stdout);
  return out;
}

// The two closed forms the meshing is judged by (as tests/kelvin/test_sphere.cpp).
// Unit cube [−0.5, 0.5]³, u_∂ = 1: V(0) = u·|x| at infinity is its capacitance C = 0.6606785
// (Hwang & Mascagni 2004), so |ln(V(0)/C)| is the far-field error of h; and the largest distance
// of the meshed boundary's vertices from the cube.
constexpr double kCubeCapacitance = 0.6606785;
struct CubeErrors {
  double v0 = 0, boundary_max = 0;
};
CubeErrors cube_errors(const Field& f) {
  const Vec3 far(1e4, 3e3, 2e3);  // |y| ≈ 1e-4
  CubeErrors e;
  e.v0 = std::exp(-f.query(far).h) * far.norm();
  for (const Vec3& x : f.boundary_points()) {
    const Vec3 q = x.cwiseAbs() - Vec3::Constant(0.5);
    const double outside = q.cwiseMax(0.0).norm();
    e.boundary_max = std::max(e.boundary_max, outside > 0 ? outside : -q.maxCoeff());
  }
  return e;
}

// Sphere R = 0.5 at the origin, σ = 0, inversion centre off its centre (else V is constant and
// exact on any mesh): h = ln(|x|/R) on the plane z = 0 in [−3, 3]², split into the region where
// the mesh is uniform in x (|x − c| < 0.65 = r_max) and the region beyond; the meshed boundary's
// face centroids (mapped to x) against the sphere.
struct SphereErrors {
  long n_verts = 0;
  double rmse = 0, rmse_near = 0, rmse_far = 0, max_abs = 0, boundary_rms = 0, t_mesh = 0;
  double mean = 0;  // the mean of h − ln(|x|/R): a constant offset is V(0)'s error
  // RMSE by |x| band, kSphereBands: where on the grid the error sits (most samples lie beyond 2)
  std::array<double, 4> band_rmse{};
  // The same error at the mesh's own vertices with 1 ≤ |x| ≤ 3√2 (no interpolation): far below
  // the grid's, the grid's error is P1 interpolation between vertices, set by the local size.
  double vertex_rmse = 0;
};
constexpr std::array<double, 4> kSphereBands = {0.5, 1, 2, 3};  // lower ends of the |x| bands
SphereErrors sphere_errors(PrepareOptions o, int grid) {
  o.centre = Vec3(0.12, -0.07, 0.05);
  Field f = Field::prepare(mesh::icosphere(0.5, 6), o);
  f.set_sigma(SigmaSpec{});
  double all = 0, near = 0, far = 0, sum = 0;
  long n_all = 0, n_near = 0, n_far = 0;
  std::array<double, 4> band{};
  std::array<long, 4> n_band{};
  SphereErrors e;
  int hint = -1;
  for (int i = 0; i < grid; ++i)
    for (int j = 0; j < grid; ++j) {
      const Vec3 x(-3 + 6.0 * (j + 0.5) / grid, -3 + 6.0 * (i + 0.5) / grid, 0);
      if (x.norm() <= 0.5) continue;
      const Sample q = f.query(x, &hint);
      if (q.status != Status::ok) continue;
      const double d = q.h - std::log(x.norm() / 0.5), d2 = d * d;
      all += d2, ++n_all, sum += d, e.max_abs = std::max(e.max_abs, std::abs(d));
      const auto b = static_cast<size_t>(std::upper_bound(kSphereBands.begin(), kSphereBands.end(), x.norm()) - kSphereBands.begin()) - 1;
      band[b] += d2, ++n_band[b];
      if ((x - *o.centre).norm() < 0.65) near += d2, ++n_near;
      else far += d2, ++n_far;
    }
  double bd = 0;
  long nb = 0;
  const TetMesh& m = f.tet_mesh();
  for (Eigen::Index c = 0; c < m.tets.rows(); ++c) {
    if (!m.in_domain[static_cast<size_t>(c)]) continue;
    for (int k = 0; k < 4; ++k) {
      const int n = m.neighbours(c, k);
      if (n >= 0 && m.in_domain[static_cast<size_t>(n)]) continue;
      Vec3 yc = Vec3::Zero();
      for (int j = 0; j < 4; ++j)
        if (j != k) yc += Vec3(m.points.row(m.tets(c, j))) / 3.0;
      const Vec3 xc = *o.centre + yc / yc.squaredNorm();
      bd += std::pow(xc.norm() - 0.5, 2), ++nb;
    }
  }
  double vs = 0;
  long nv = 0;
  for (Eigen::Index v = 0; v < m.points.rows(); ++v) {
    const Vec3 y = m.points.row(v);
    if (y.squaredNorm() == 0) continue;
    const Vec3 x = *o.centre + y / y.squaredNorm();
    if (x.norm() < 1 || x.norm() > 3 * std::sqrt(2.0)) continue;
    const Sample q = f.query(x, &hint);
    if (q.status != Status::ok) continue;
    vs += std::pow(q.h - std::log(x.norm() / 0.5), 2), ++nv;
  }
  e.vertex_rmse = std::sqrt(vs / static_cast<double>(std::max(nv, 1L)));
  e.n_verts = f.stats().n_verts;
  e.t_mesh = f.stats().t_mesh;
  e.rmse = std::sqrt(all / std::max(n_all, 1L));
  e.rmse_near = std::sqrt(near / std::max(n_near, 1L));
  e.rmse_far = std::sqrt(far / std::max(n_far, 1L));
  e.mean = sum / static_cast<double>(std::max(n_all, 1L));
  for (size_t b = 0; b < band.size(); ++b) e.band_rmse[b] = std::sqrt(band[b] / static_cast<double>(std::max(n_band[b], 1L)));
  e.boundary_rms = std::sqrt(bd / std::max(nb, 1L));
  return e;
}

// Accuracy against vertices for the paper's sizing (eq. 23, grading 0) and graded ones, side by
// side at each l_x: the cube's capacitance error and the sphere's RMSE of h, with N_verts and
// t_mesh (every row is meshed and solved: a 400k-vertex factorization takes tens of minutes here).
nlohmann::json sizing_table(const std::vector<double>& lxs, const std::vector<double>& gradings, double far_radius, int grid, int mesh_threads) {
  std::printf(
      "\nAccuracy against vertices: cube |ln(V(0)/C)| (C = %.7f) and sphere RMSE of h (%d × %d grid, z = 0, [-3, 3]²); "
      "grading 0 is the paper's sizing (eq. 23)\n"
      "| l_x | grading | cube N_verts | cube N_tets | t_mesh s | t_decomp s | ln(V(0)/C) | boundary max / l_x² | sphere N_verts | "
      "sphere t_mesh s | sphere RMSE | mean dh | RMSE |x| 0.5–1 | 1–2 | 2–3 | ≥3 | max |dh| |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
      kCubeCapacitance, grid, grid);
  nlohmann::json out = nlohmann::json::array();
  for (double lx : lxs)
    for (double g : gradings) {
      PrepareOptions o;
      o.lx = lx;
      o.far_radius = far_radius;
      o.grading = g;
      o.mesh_threads = mesh_threads;
      o.max_vertices = 2'000'000;
      CubeErrors c;
      Stats st;
      {  // the cube's factor is freed before the sphere is prepared
        Field cube = Field::prepare(mesh::box(Vec3::Ones()), o);
        cube.set_sigma(SigmaSpec{}, false);
        c = cube_errors(cube);
        st = cube.stats();
      }
      const SphereErrors sp = sphere_errors(o, grid);
      const double cap = std::log(c.v0 / kCubeCapacitance);
      std::printf("| %.3g | %.2f | %ld | %ld | %.2f | %.2f | %+.3e | %.3f | %ld | %.2f | %.3e | %+.2e | %.2e | %.2e | %.2e | %.2e | %.2e |\n", lx, g,
                  st.n_verts, st.n_tets, st.t_mesh, st.t_decomp, cap, c.boundary_max / (lx * lx), sp.n_verts, sp.t_mesh,
                  sp.rmse, sp.mean, sp.band_rmse[0], sp.band_rmse[1], sp.band_rmse[2], sp.band_rmse[3], sp.max_abs);
      std::fflush(stdout);
      out.push_back({{"lx", lx}, {"grading", g}, {"cube_n_verts", st.n_verts}, {"cube_n_tets", st.n_tets}, {"cube_t_mesh", st.t_mesh}, {"cube_t_decomp", st.t_decomp}, {"log_v0_over_capacitance", cap}, {"boundary_max_distance", c.boundary_max}, {"sphere_n_verts", sp.n_verts}, {"sphere_t_mesh", sp.t_mesh}, {"sphere_rmse", sp.rmse}, {"sphere_rmse_near", sp.rmse_near}, {"sphere_rmse_far", sp.rmse_far}, {"sphere_mean", sp.mean}, {"sphere_band_rmse", sp.band_rmse}, {"sphere_max_abs", sp.max_abs}});
    }
  return out;
}

// Issue 38's mesher table: distlab's mesher against plain CGAL Mesh_3 with the paper's sizing
// (eq. 23) on the same inverted surface (kelvin::meshing_surface; distlab-mesh3-plain, a child
// process), in one run, the sides alternating which goes first. "Ours" is what Stats::t_mesh
// times in a preparation: the sizing's choice (grading "auto"), Mesh_3 and the manifold boundary.
struct MesherCase {
  std::string object;
  mesh::SurfaceMesh surface;
  Vec3 centre;
  double lx = 0, feature_angle = 60;
  std::optional<double> grading;  // none: choose_grading, as a preparation without one
};
struct MesherSide {
  std::vector<double> t;
  long n_verts = 0;
  std::vector<long> n_verts_runs;
  double grading = 0;
  double t_refine = 0, t_exude = 0;  // plain: the means of Mesh_3's refinement and exudation
  double t_choice = 0;               // ours: choose_grading's part of t (grading "auto"), mean
  std::string digest;                // ours: SHA-256 of the points, cells and domain flags (same mesh, same digest)
};

MeshingParams mesher_params(const MesherCase& c, double far_radius, mesh::SurfaceMesh& inverted) {
  inverted = c.surface;
  double r_max = 0;
  for (Eigen::Index v = 0; v < inverted.vertices.rows(); ++v) {
    const Vec3 p = Vec3(inverted.vertices.row(v)) - c.centre;
    r_max = std::max(r_max, p.norm());
    inverted.vertices.row(v) = p / p.squaredNorm();  // eq. 5
  }
  MeshingParams params;  // as Field::prepare sets them (field.cpp, mesh_stage)
  params.lx = c.lx;
  params.min_size = c.lx / std::pow(far_radius * r_max, 2);
  params.feature_angle = c.feature_angle;
  params.max_vertices = 2'000'000;
  params.max_protection_evaluations = 1e7;  // the bench's objects converge (the wrench runs without protection)
  return params;
}

// worker (a distlab executable): threads > 1 mesh in its child process, as the service does
// (kelvin/isolated_mesher.hpp); a child that failed is an error here, not a retry.
void ours_once(const MesherCase& c, double far_radius, int threads, const std::string& worker, MesherSide& out) {
  mesh::SurfaceMesh inverted;
  MeshingParams params = mesher_params(c, far_radius, inverted);
  params.threads = threads;
  const auto t0 = Clock::now();
  params.grading = c.grading ? *c.grading : choose_grading(inverted, params);
  out.t_choice += since(t0);
  TetMesh tm;
  if (threads > 1 && !worker.empty()) {
    IsolatedMeshing report;
    tm = mesh_inverted_domain_isolated(inverted, params, {}, report, worker);
    if (!report.retried.empty()) throw std::runtime_error(report.retried);
  } else {
    tm = mesh_inverted_domain(inverted, params, {});
  }
  make_boundary_manifold(tm);
  out.t.push_back(since(t0));
  out.n_verts = tm.points.rows();
  out.n_verts_runs.push_back(out.n_verts);
  out.grading = params.grading;
  Sha256 sha;
  sha.add(tm.points.data(), sizeof(double) * static_cast<size_t>(tm.points.size()));
  sha.add(tm.tets.data(), sizeof(int) * static_cast<size_t>(tm.tets.size()));
  sha.add(tm.in_domain.data(), tm.in_domain.size());
  const std::string digest = sha.hex();
  // One thread is deterministic; parallel refinement is not (MeshingParams::threads).
  if (threads == 1 && !out.digest.empty() && digest != out.digest) throw std::runtime_error("the mesher made two different meshes of one input");
  out.digest = threads == 1 ? digest : "(parallel)";
}

void plain_once(const MesherCase& c, double far_radius, int threads, const std::string& exe, MesherSide& out) {
  mesh::SurfaceMesh inverted;
  const MeshingParams params = mesher_params(c, far_radius, inverted);
  const mesh::SurfaceMesh poly = meshing_surface(inverted, params);
  const std::string off = "/tmp/distlab-bench-kelvin-" + std::to_string(::getpid()) + ".off";
  {
    std::ofstream f(off);
    f << "OFF\n"
      << poly.vertices.rows() << " " << poly.faces.rows() << " 0\n";
    char line[128];
    for (Eigen::Index v = 0; v < poly.vertices.rows(); ++v) {
      std::snprintf(line, sizeof line, "%.17g %.17g %.17g\n", poly.vertices(v, 0), poly.vertices(v, 1), poly.vertices(v, 2));
      f << line;
    }
    for (Eigen::Index k = 0; k < poly.faces.rows(); ++k) f << "3 " << poly.faces(k, 0) << " " << poly.faces(k, 1) << " " << poly.faces(k, 2) << "\n";
  }
  char args[256];
  std::snprintf(args, sizeof args, " %s %.17g %.17g %.17g %d", off.c_str(), params.lx, params.min_size, params.feature_angle, threads);
  FILE* p = ::popen((exe + args).c_str(), "r");
  if (p == nullptr) throw std::runtime_error("cannot start " + exe);
  std::string text;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p) != nullptr) text += buf;
  const int status = ::pclose(p);
  std::remove(off.c_str());
  if (status != 0) throw std::runtime_error(exe + " failed: " + text);
  const nlohmann::json j = nlohmann::json::parse(text);
  out.t.push_back(j.at("t_mesh").get<double>());
  out.n_verts = j.at("n_verts").get<long>();
  out.n_verts_runs.push_back(out.n_verts);
  out.t_refine += j.at("t_refine").get<double>();
  out.t_exude += j.at("t_exude").get<double>();
}

nlohmann::json mesher_table(const std::vector<MesherCase>& cases, double far_radius, int reps, const std::vector<int>& thread_counts,
                            const std::string& plain_exe, const std::string& worker) {
  const std::string load_before = bench::load_average();
  std::printf(
      "\nMesher (issue 38): distlab's (the sizing's choice, Mesh_3, the manifold boundary: Stats::t_mesh) against "
      "plain CGAL Mesh_3 with eq. 23 on the same inverted surface (%s) on as many threads (1: Sequential_tag, more: "
      "Parallel_tag; ours in a child process of %s where given), medians of %d runs alternating which goes first; load before: %s\n| object | l_x | sizing | threads | "
      "N_verts (runs) | t_mesh s | of it sizing choice s | µs/vertex | plain N_verts | plain t s | plain refine s | plain exude s | "
      "plain µs/vertex | t ratio | per-vertex ratio | mesh digest |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
      plain_exe.c_str(), worker.empty() ? "none" : worker.c_str(), reps, load_before.c_str());
  nlohmann::json out = nlohmann::json::array();
  for (const MesherCase& c : cases)
    for (const int threads : thread_counts) {
      MesherSide ours, plain;
      for (int r = 0; r < reps; ++r)
        for (int side = 0; side < 2; ++side) {
          if ((side == 0) == (r % 2 == 0)) ours_once(c, far_radius, threads, worker, ours);
          else if (!plain_exe.empty()) plain_once(c, far_radius, threads, plain_exe, plain);
        }
      const double t = median(ours.t), tp = plain.t.empty() ? std::nan("") : median(plain.t);
      const double us = 1e6 * t / static_cast<double>(ours.n_verts), usp = 1e6 * tp / static_cast<double>(plain.n_verts);
      const auto [lo, hi] = std::minmax_element(ours.n_verts_runs.begin(), ours.n_verts_runs.end());
      const std::string counts = *lo == *hi ? std::to_string(*lo) : std::to_string(*lo) + "–" + std::to_string(*hi);
      std::printf("| %s | %.3g | %s | %d | %s | %.2f | %.2f | %.1f | %ld | %.2f | %.2f | %.2f | %.1f | %.2f | %.2f | %s |\n", c.object.c_str(), c.lx,
                  (c.grading ? std::to_string(ours.grading).substr(0, 4) : "auto " + std::to_string(ours.grading).substr(0, 4)).c_str(),
                  threads, counts.c_str(), t, ours.t_choice / reps, us, plain.n_verts, tp, plain.t_refine / reps, plain.t_exude / reps, usp, t / tp,
                  us / usp, ours.digest.substr(0, 12).c_str());
      std::fflush(stdout);
      out.push_back({{"object", c.object}, {"lx", c.lx}, {"grading", ours.grading}, {"grading_chosen", !c.grading}, {"threads", threads}, {"isolated", threads > 1 && !worker.empty()}, {"n_verts", ours.n_verts}, {"n_verts_runs", ours.n_verts_runs}, {"digest", ours.digest}, {"t_mesh", t}, {"t_mesh_runs", ours.t}, {"plain_n_verts", plain.n_verts}, {"plain_n_verts_runs", plain.n_verts_runs}, {"plain_t_mesh", tp}, {"plain_t_mesh_runs", plain.t}, {"plain_t_refine_mean", plain.t_refine / reps}, {"plain_t_exude_mean", plain.t_exude / reps}, {"t_sizing_choice_mean", ours.t_choice / reps}});
    }
  const std::string load_after = bench::load_average();
  std::printf("load after: %s\n", load_after.c_str());
  return {{"rows", out}, {"load_before", load_before}, {"load_after", load_after}, {"reps", reps}};
}

std::vector<double> parse_list(const std::string& s) {
  std::vector<double> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) out.push_back(std::stod(item));
  return out;
}

}  // namespace

// A failing benchmark ends on its uncaught exception (std::terminate prints it).
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  distlab::app::use_huge_page_heap(argv);
  std::vector<double> lxs = {0.2, 0.15, 0.1, 0.08, 0.06, 0.05, 0.04, 0.03, 0.02};
  std::string assets = "assets", json_path = "bench_kelvin.json", cache_dir;
  int grid = 1000;
  long lu_max = 60000;
  double wrench_lx = 0.002, wrench_features = 180, far_radius = 1.0;
  bool table1 = true, table2 = true;
  std::vector<double> sphere_lxs, sizing_lxs, gradings = {0.0, 0.3}, mesher_lxs;
  std::string mesher_gradings = "auto,0", mesher_objects = "cube,wrench";
  int mesher_reps = 3;
  std::vector<int> mesher_threads = {1};
  int mesh_threads = 0;  // PrepareOptions::mesh_threads of every preparation (0: chosen)
  bool mesher_plain = true;
  std::string mesher_worker, mesh_worker;
  std::optional<double> grading = 0.0;  // none: chosen per object (choose_grading), as the service
  if (argc == 2 && std::string(argv[1]) == "--help") {
    std::puts(
        "usage: distlab-bench-kelvin [--assets DIR] [--lx 0.2,0.15,...] [--grid 1000] [--lu-max 60000]\n"
        "  [--wrench-lx 0.002] [--wrench-features 180] [--json FILE] [--table2-only 1] [--table1-only 1]\n"
        "  [--sphere-rmse 0.1,0.05,...] [--cache-dir DIR (reuse prepared objects)] [--far-radius 1] [--grading 0 (or auto)]\n"
        "  [--mesh-threads 0 (every preparation's PrepareOptions::mesh_threads; 0: chosen, 1: one thread)]\n"
        "  [--mesh-worker build/backend/app/distlab (PrepareOptions::mesh_worker: threads > 1 mesh in its child, as the service)]\n"
        "  [--sizing-table 0.05,0.03 (accuracy against vertices, per grading) [--gradings 0,0.3]]\n"
        "  [--mesher 0.03,0.02 (the mesher against plain CGAL Mesh_3, eq. 23) [--mesher-gradings auto,0]\n"
        "   [--mesher-objects cube,wrench (the wrench at --wrench-lx)] [--mesher-reps 3] [--mesher-threads 1,2 (ours and plain's)]\n"
        "   [--mesher-plain 0 (ours only)] [--mesher-worker build/backend/app/distlab (ours on threads > 1 in its child, as the service)]]");
    return 0;
  }
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    try {
      if (k == "--lx") lxs = parse_list(v);
      else if (k == "--grid") grid = std::stoi(v);
      else if (k == "--lu-max") lu_max = std::stol(v);
      else if (k == "--assets") assets = v;
      else if (k == "--wrench-lx") wrench_lx = std::stod(v);
      else if (k == "--wrench-features") wrench_features = std::stod(v);
      else if (k == "--json") json_path = v;
      else if (k == "--cache-dir") cache_dir = v;
      else if (k == "--far-radius") far_radius = std::stod(v);  // PrepareOptions::far_radius of the cube and sphere
      else if (k == "--table2-only") table1 = v == "0";
      else if (k == "--table1-only") table2 = v == "0";
      else if (k == "--sphere-rmse") sphere_lxs = parse_list(v), table1 = table2 = false;
      else if (k == "--mesh-threads") mesh_threads = std::stoi(v);                                            // PrepareOptions::mesh_threads of every preparation
      else if (k == "--grading") grading = v == "auto" ? std::nullopt : std::optional<double>(std::stod(v));  // of every object
      else if (k == "--mesh-worker") mesh_worker = v;
      else if (k == "--sizing-table") sizing_lxs = parse_list(v), table1 = table2 = false;
      else if (k == "--gradings") gradings = parse_list(v);
      else if (k == "--mesher") mesher_lxs = parse_list(v), table1 = table2 = false;
      else if (k == "--mesher-gradings") mesher_gradings = v;
      else if (k == "--mesher-objects") mesher_objects = v;
      else if (k == "--mesher-reps") mesher_reps = std::stoi(v);
      else if (k == "--mesher-threads") {
        mesher_threads.clear();
        for (double n : parse_list(v)) mesher_threads.push_back(static_cast<int>(n));
      } else if (k == "--mesher-plain") mesher_plain = v != "0";
      else if (k == "--mesher-worker") mesher_worker = v;
      else {
        std::fprintf(stderr, "unknown option %s\n", k.c_str());
        return 2;
      }
    } catch (const std::logic_error&) {  // std::stod and the like: not a number, or out of range
      std::fprintf(stderr, "%s: not a valid value: %s\n", k.c_str(), v.c_str());
      return 2;
    }
  }
  std::sort(lxs.rbegin(), lxs.rend());
  const mesh::SurfaceMesh cube = mesh::box(Vec3::Ones());
  SigmaSpec zero;  // u_∂ = 1, as in Fig. 3

  // Query sets (hinted path, hint-less random points; the AABB baseline uses the random set).
  const auto [path, random] = bench::kelvin_query_sets();

  // Table I. RMSE of h against the finest l_x on a grid × grid plane z = 0 in [−3, 3]² (the
  // paper's definition; points inside the cube have no h and are left out). Beside it two exact
  // checks: V(0) = u·|x| at infinity is the cube's capacitance C = 0.6606785 (Hwang & Mascagni
  // 2004), so |ln(V(0)/C)| is the far-field error of h; and the largest distance of the meshed
  // boundary's vertices from the cube.
  std::vector<Row> rows;
  std::vector<std::vector<double>> planes;
  std::vector<std::pair<double, double>> exact;  // V(0), boundary max distance
  for (double lx : table1 ? lxs : std::vector<double>{}) {
    std::optional<Field> kept;
    PrepareOptions o;
    o.lx = lx;
    o.far_radius = far_radius;
    o.grading = grading;
    o.mesh_threads = mesh_threads;
    o.mesh_worker = mesh_worker;
    rows.push_back(run(cube, o, {zero}, path, random, lu_max, cache_dir, &kept));
    const Field& f = *kept;
    std::vector<double> plane(static_cast<size_t>(grid) * grid);
    int hint = -1;
    for (int i = 0; i < grid; ++i)
      for (int j = 0; j < grid; ++j)
        plane[static_cast<size_t>(i) * grid + j] =
            f.query(Vec3(-3 + 6.0 * (j + 0.5) / grid, -3 + 6.0 * (i + 0.5) / grid, 0), &hint).h;
    planes.push_back(std::move(plane));
    const CubeErrors e = cube_errors(f);
    exact.emplace_back(e.v0, e.boundary_max);
    std::fprintf(stderr, "lx %.3g done (%ld vertices)\n", lx, rows.back().stats.n_verts);
    print("Table I so far", {rows.back()});
  }
  for (size_t k = 0; k + 1 < rows.size(); ++k) {
    double sum = 0;
    long n = 0;
    for (size_t p = 0; p < planes.back().size(); ++p)
      if (std::isfinite(planes[k][p]) && std::isfinite(planes.back()[p])) {
        sum += (planes[k][p] - planes.back()[p]) * (planes[k][p] - planes.back()[p]);
        ++n;
      }
    rows[k].rmse = std::sqrt(sum / std::max(n, 1L));
  }
  if (table1) std::printf("\nRMSE of h against l_x = %.3g on a %d × %d grid in [−3, 3]² (z = 0)\n", lxs.back(), grid, grid);
  if (table1) print("Table I: unit cube (times in s; t_solve, t_grad, chol_ms, LU_solve in ms; q_*, AABB in µs)", rows);
  const Stream stream_1t = stream_gbps(1), stream_2t = stream_gbps(2);
  nlohmann::json bandwidth = table1 ? print_bandwidth(rows, stream_1t, stream_2t) : nlohmann::json();
  // Observed orders between consecutive rows: log(e_k / e_k+1) / log(l_x,k / l_x,k+1). The RMSE
  // against the finest mesh carries that mesh's own error, so its order is biased low near it.
  nlohmann::json accuracy;
  if (table1) {
    std::printf(
        "\nTable I accuracy: RMSE against l_x = %.3g and exact checks (C = %.7f)\n"
        "| l_x | N_verts | RMSE | order | V(0) | ln(V(0)/C) | order | boundary max dist | / l_x² |\n"
        "|---|---|---|---|---|---|---|---|---|\n",
        lxs.back(), kCubeCapacitance);
    for (size_t k = 0; k < rows.size(); ++k) {
      auto order = [&](double a, double b) {
        return k == 0 ? std::nan("") : std::log(std::abs(a / b)) / std::log(rows[k - 1].lx / rows[k].lx);
      };
      const double err = std::log(exact[k].first / kCubeCapacitance);
      const double rmse_order = k + 1 < rows.size() ? order(k > 0 ? rows[k - 1].rmse : 1, rows[k].rmse) : std::nan("");
      const double cap_order = k > 0 ? order(std::log(exact[k - 1].first / kCubeCapacitance), err) : std::nan("");
      std::printf("| %.3g | %ld | %.5f | %.2f | %.6f | %+.2e | %.2f | %.2e | %.3f |\n", rows[k].lx, rows[k].stats.n_verts,
                  rows[k].rmse, rmse_order, exact[k].first, err, cap_order, exact[k].second,
                  exact[k].second / (rows[k].lx * rows[k].lx));
      accuracy.push_back({{"lx", rows[k].lx}, {"rmse", rows[k].rmse}, {"v0", exact[k].first}, {"log_v0_over_capacitance", err}, {"boundary_max_distance", exact[k].second}});
    }
    std::fflush(stdout);
  }

  // Table II: the wrench, centre of inversion at its centre (as the paper), σ cases (a), (b), (c)
  // of Section V-B (eq. 24, as in assets/wrench_case_*.json); t_solve of case (a).
  std::vector<Row> wrench_rows;
  if (table2) try {
      const mesh::SurfaceMesh wrench = mesh::weld(mesh::load_mesh(assets + "/wrench.stl")).surface;
      std::vector<SigmaSpec> cases(3);
      cases[0].axis.push_back({Vec3::UnitX(), Vec3::Zero(), 0.03, -1.0, 0.003});
      cases[1].constant = -1.0;
      cases[2].axis.push_back({Vec3::UnitX(), Vec3::Zero(), 0.03, 1.0, 0.003});
      std::vector<Vec3> wpath, wrandom;
      for (const Vec3& x : path) wpath.emplace_back(x * 0.04);
      for (const Vec3& x : random) wrandom.emplace_back(x * 0.04);
      PrepareOptions o;
      o.lx = wrench_lx;
      o.centre = Vec3::Zero();
      o.feature_angle = wrench_features;
      o.grading = grading;
      o.mesh_threads = mesh_threads;
      o.mesh_worker = mesh_worker;
      std::fprintf(stderr, "wrench: lx %.4g, feature_angle %.0f\n", o.lx, o.feature_angle);
      wrench_rows.push_back(run(wrench, o, cases, wpath, wrandom, lu_max, cache_dir));
      for (const std::string& w : wrench_rows.back().stats.warnings) std::printf("warning: %s\n", w.c_str());
      print("Table II: combination wrench", wrench_rows);
      print_bandwidth(wrench_rows, stream_1t, stream_2t);
      std::printf("t_solve per case (a), (b), (c): %.2f, %.2f, %.2f ms\n", wrench_rows[0].case_solve_ms[0],
                  wrench_rows[0].case_solve_ms[1], wrench_rows[0].case_solve_ms[2]);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "wrench skipped: %s\n", e.what());
    }

  // RMSE against the exact field of a sphere (radius 0.5, σ = 0, inversion centre off its centre
  // as in tests/kelvin): h = ln(|x|/R), on the plane z = 0 in [−3, 3]², split into the region
  // where the mesh is uniform in x (|x − c| ≤ far_radius · r_max) and the far region beyond.
  nlohmann::json sphere_json;
  if (!sphere_lxs.empty()) {
    std::printf(
        "\nSphere R = 0.5, centre of inversion (0.12, -0.07, 0.05): h against ln(|x|/R) on a %d × %d grid, z = 0, [-3, 3]²\n"
        "| l_x | N_verts | RMSE | RMSE |x−c|<0.65 | RMSE beyond | mean dh | RMSE |x| 0.5–1 | 1–2 | 2–3 | ≥3 | vertex RMSE 1≤|x|≤3√2 | max |dh| | boundary RMS dist / l_x |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        grid, grid);
    for (double lx : sphere_lxs) {
      PrepareOptions o;
      o.lx = lx;
      o.far_radius = far_radius;
      o.grading = grading;
      o.mesh_threads = mesh_threads;
      o.mesh_worker = mesh_worker;
      const SphereErrors e = sphere_errors(o, grid);
      std::printf("| %.3g | %ld | %.3e | %.2e | %.2e | %+.2e | %.2e | %.2e | %.2e | %.2e | %.2e | %.4f | %.4f |\n", lx, e.n_verts, e.rmse, e.rmse_near,
                  e.rmse_far, e.mean, e.band_rmse[0], e.band_rmse[1], e.band_rmse[2], e.band_rmse[3], e.vertex_rmse, e.max_abs, e.boundary_rms / lx);
      std::fflush(stdout);
      sphere_json.push_back({{"lx", lx}, {"n_verts", e.n_verts}, {"rmse", e.rmse}, {"rmse_near", e.rmse_near}, {"rmse_far", e.rmse_far}, {"mean", e.mean}, {"band_rmse", e.band_rmse}, {"vertex_rmse", e.vertex_rmse}, {"max_abs", e.max_abs}, {"boundary_rms_over_lx", e.boundary_rms / lx}});
    }
  }

  nlohmann::json out;
  if (!mesher_lxs.empty()) {
    std::vector<std::optional<double>> sizings;
    {
      std::stringstream ss(mesher_gradings);
      for (std::string item; std::getline(ss, item, ',');)
        sizings.push_back(item == "auto" ? std::nullopt : std::optional<double>(std::stod(item)));
    }
    std::vector<MesherCase> cases;
    std::stringstream ss(mesher_objects);
    for (std::string object; std::getline(ss, object, ',');) {
      if (object != "cube" && object != "wrench") throw std::runtime_error("--mesher-objects: cube or wrench");
      const mesh::SurfaceMesh surface = object == "cube" ? cube : mesh::weld(mesh::load_mesh(assets + "/wrench.stl")).surface;
      for (double lx : object == "cube" ? mesher_lxs : std::vector<double>{wrench_lx})
        for (const auto& g : sizings) cases.push_back({object, surface, Vec3::Zero(), lx, object == "cube" ? 60.0 : wrench_features, g});
    }
    const std::string exe = std::filesystem::canonical("/proc/self/exe").parent_path() / "distlab-mesh3-plain";
    out["mesher"] = mesher_table(cases, far_radius, mesher_reps, mesher_threads, mesher_plain ? exe : "", mesher_worker);
  }
  if (!sizing_lxs.empty()) out["sizing"] = sizing_table(sizing_lxs, gradings, far_radius, grid, mesh_threads);
  if (!sphere_json.is_null()) out["sphere_rmse"] = sphere_json;
  for (const Row& r : rows) out["table1"].push_back(to_json(r));
  if (!accuracy.is_null()) out["table1_accuracy"] = accuracy;
  if (!bandwidth.is_null()) out["table1_bandwidth"] = bandwidth;
  for (const Row& r : wrench_rows) out["table2"].push_back(to_json(r));
  std::ofstream(json_path) << out.dump(2) << "\n";
  std::printf("\nwrote %s\n", json_path.c_str());
  return 0;
}
