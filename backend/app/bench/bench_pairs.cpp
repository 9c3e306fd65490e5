// GAP public benchmark (issue 19): random pairs of all five shape kinds (polytopes, boxes,
// cylinders, capsules, spheres), a third each separated, touching (Euclidean distance in
// (0, 1e-6]) and overlapping; per pair GAP Newton's and FCL's time, Newton's iterations, the
// agreement of Λ between Newton and the plain iteration, and the finite-difference error of
// GAP's pose gradients. FCL's distance is reported beside GAP's.
//   distlab-bench-pairs [--pairs N] [--first F] [--seed S] [--passes P] [--chunk C] [--plain-every K]
//     [--fd-every K] [--threads T] [--csv FILE[.gz]] [--json FILE] [--check]
// --first F: pairs F to F + N − 1 (pair i is drawn from (seed, i) alone: one pair of a larger run
// is run again as it was there).
// --passes P: per pair the fastest of P cold calls (each pass over a chunk of C pairs, default
// 4096, evicts the pair from cache before the next). --plain-every/--fd-every K: the plain
// iteration (up to 1e5 steps near contact) and the finite-difference solves on every K-th
// pair of each regime only (default 1: all). --csv: one row per pair, gzip-compressed when the
// name ends in .gz; plot with backend/app/bench/plot_pairs.py. --check: exit 1 when a pair's Λ
// agreement exceeds 1e-8 where D >= 1e-4 or its gradient error (finite differences of D in long
// double) 1e-6 on any pair (issue 19; no time is checked). Drawing and checking run on T threads
// (default 2); the timed calls on one thread, alone. GAP's time includes its Euclidean start (double GJK), as in distlab-bench-gap.
// Issue 19's run (with these flags 20k pairs take 18 s of CPU, 12 s with the former double fit;
// the 1e6 run took 61 min at nice 10 on a shared, loaded 2-core machine):
//   distlab-bench-pairs --pairs 1000000 --passes 3 --plain-every 100 --fd-every 10 --check
//     --csv pairs.csv.gz --json pairs.json
#include <zlib.h>

#include <array>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <string>

#include "../src/huge_page_heap.hpp"
#include "gap_cases.hpp"

using namespace distlab;
using namespace distlab::bench;

namespace {

constexpr double kAgreementBound = 1e-8;  // relative on Λ (issue 19's oracle tolerance)
constexpr double kGradientBound = 1e-6;   // relative, finite differences against the gradient
constexpr double kTouching = 1e-6;        // Euclidean distance of a touching pair
constexpr double kPlainStep = 1e-9;       // the plain iteration's stop rule, relative to D
constexpr int kPlainIterations = 100'000;
// Below D ~ 1e-8 the plain iteration's step underflows against |a| (it stops where it starts),
// and for D < 1e-4 it does not reach its stop rule in 1e5 steps: the Λ agreement is asserted
// where D >= 1e-4 (or on overlap), and reported everywhere. The gradient is asserted on every
// pair.
constexpr double kResolvedD = 1e-4;

enum class Regime { separated,
                    touching,
                    overlapping };
constexpr std::array<const char*, 3> kRegimes = {"separated", "touching", "overlapping"};
constexpr std::array<const char*, 5> kKinds = {"polytope", "box", "cylinder", "capsule", "sphere"};

Shape random_shape(int kind, std::mt19937_64& rng) {
  auto u = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  switch (kind) {
    case 0:
      return random_polytope(rng);
    case 1:
      return Box{Vec3(u(0.05, 0.4), u(0.05, 0.4), u(0.05, 0.4))};
    case 2:
      return Cylinder{u(0.025, 0.2), u(0.05, 0.4)};
    case 3:
      return Capsule{u(0.025, 0.1), u(0.05, 0.3)};
    default:
      return Sphere{u(0.025, 0.2)};
  }
}

struct Pair {
  int kind_a, kind_b;
  Regime regime;
  GapBody a, b;
  double euclidean;  // certified (distlab's duality-gap-checked FCL)
};

// A pair of the given kinds and regime. B is placed at random, then translated along the
// Euclidean separating direction n: moving B by −s n lowers the distance d by exactly s (the
// separating plane stays one), so a touching pair is built at a chosen distance in (0, 1e-6]
// and an overlapping one at a chosen depth along n; each is checked by the certified distance.
Pair make_pair(int kind_a, int kind_b, Regime regime, std::mt19937_64& rng) {
  const GapParams params = paper_params();
  std::uniform_real_distribution<double> pos(-0.5, 0.5), unit(0, 1);
  for (;;) {
    const Shape sa = random_shape(kind_a, rng), sb = random_shape(kind_b, rng);
    const Pose pa{Vec3::Zero(), random_rotation(rng)};
    Pose pb{Vec3(pos(rng), pos(rng), pos(rng)), random_rotation(rng)};
    const P2SOptions oa = kind_a == 0 ? paper_polytope_options() : P2SOptions{};
    const P2SOptions ob = kind_b == 0 ? paper_polytope_options() : P2SOptions{};
    Pair p{kind_a, kind_b, regime, GapBody(sa, pa, params, oa), GapBody(sb, pb, params, ob), 0};
    const auto e = euclidean_distance(p.a.euclidean(), pa, p.b.euclidean(), pb);
    if (!(e.distance > 1e-3)) continue;
    const Vec3 n = (e.witness_b - e.witness_a) / (e.witness_b - e.witness_a).norm();
    double target;  // the distance after the move; < 0: a depth along n
    if (regime == Regime::separated) target = std::pow(10.0, -3 + unit(rng) * std::log10(500.0));
    else if (regime == Regime::touching) target = kTouching * (0.1 + 0.9 * unit(rng));
    else target = -std::pow(10.0, -4 + unit(rng) * std::log10(500.0));
    if (target > e.distance) continue;
    pb.position -= (e.distance - target) * n;
    p.b.set_pose(pb);
    p.euclidean = euclidean_distance(p.a.euclidean(), pa, p.b.euclidean(), pb).distance;
    const bool ok = regime == Regime::separated  ? p.euclidean > kTouching
                    : regime == Regime::touching ? p.euclidean > 0 && p.euclidean <= kTouching
                                                 : p.euclidean <= 0;
    if (ok) return p;
  }
}

struct Row {
  double gap_us = INFINITY, fcl_us = INFINITY;
  GapResult newton;
  double fcl_distance = 0;
  double lambda_plain = 0;
  int plain_iterations = 0;
  bool plain_run = false, plain_converged = false, fd_run = false;
  double agreement = 0;       // |Λ_Newton − Λ_plain| / Λ_Newton (0 on overlap: both 0)
  double gradient_error = 0;  // ‖FD − ∇D‖∞ / ‖∇D‖∞ over both poses' 12 coordinates
  bool fd_converged = true;   // every long-double solve of the finite differences converged
};

// Finite differences of D along each of the 12 pose coordinates (linear, then world-frame
// rotation of A, then of B), central at 1e-4 d (at most 1e-6), with D and the poses in long
// double (gap_gradient_extended). Near contact (d <= 1e-6, D 1e-16 to 1e-22) D's rounding in
// double, up to ~1e-9 relative (s = u·p − b ~ d/2 against |p| ~ 0.3), made a double difference
// quotient err by up to 7e-6 where the gradient was right, and even a 40-solve least-squares
// slope could not judge 11 to 19 of ~6,700 touching pairs at 1e-6; in long double the rounding
// is 2048× smaller. The step's truncation error is ~(1e-4)² of the gradient (D ~ d^2.75).
double gradient_error(const Pair& p, const GapResult& r, bool& converged) {
  const double step = p.euclidean > 0 ? std::min(1e-6, 1e-4 * p.euclidean) : 1e-6;
  const ExtendedGradient fd = gap_gradient_extended(p.a, p.b, r, step);
  converged = fd.converged;
  double worst = 0, scale = 0;
  for (int c = 0; c < 6; ++c) {
    worst = std::max({worst, std::abs(fd.a[c] - r.gradient_a[c]), std::abs(fd.b[c] - r.gradient_b[c])});
    scale = std::max({scale, std::abs(r.gradient_a[c]), std::abs(r.gradient_b[c])});
  }
  return scale > 0 ? worst / scale : worst;
}

// A CSV written through zlib when the name ends in .gz (1e6 rows: ~150 MB plain, ~50 MB gzip).
class CsvOut {
 public:
  explicit CsvOut(const std::string& path) {
    if (path.empty()) return;
    const std::string mode = path.size() > 3 && path.substr(path.size() - 3) == ".gz" ? "wb6" : "wT";
    gz_ = gzopen(path.c_str(), mode.c_str());
  }
  ~CsvOut() {
    if (gz_) gzclose(gz_);
  }
  CsvOut(const CsvOut&) = delete;
  CsvOut& operator=(const CsvOut&) = delete;
  bool failed(const std::string& path) const { return !path.empty() && !gz_; }
  void line(const std::string& s) {
    if (gz_) gzwrite(gz_, s.data(), static_cast<unsigned>(s.size()));
  }

 private:
  gzFile gz_ = nullptr;
};

// Summary of a set of pairs: one row of the printed tables and of the JSON.
struct Bucket {
  std::vector<double> gap_us, fcl_us, iterations, agreement, gradient;
  std::vector<double> agreement_resolved;  // D >= kResolvedD
  int pairs = 0, newton_unconverged = 0, plain_run = 0, plain_unconverged = 0, fd_run = 0;
  int gradient_failed = 0, fd_unconverged = 0;  // error > bound; a reference solve unconverged
  void add(const Row& r) {
    ++pairs;
    gap_us.push_back(r.gap_us);
    fcl_us.push_back(r.fcl_us);
    iterations.push_back(r.newton.iterations);
    const bool resolved = r.newton.distance >= kResolvedD || r.newton.overlap;
    if (r.fd_run) {
      ++fd_run;
      gradient.push_back(r.gradient_error);
      if (!(r.gradient_error <= kGradientBound) || !r.fd_converged) ++gradient_failed;
      if (!r.fd_converged) ++fd_unconverged;
    }
    if (!r.newton.converged) ++newton_unconverged;
    if (r.plain_run) {
      ++plain_run;
      if (!r.plain_converged) ++plain_unconverged;
      else agreement.push_back(r.agreement);
      if (r.plain_converged && resolved) agreement_resolved.push_back(r.agreement);
    }
  }
  void print(const std::string& name) const {
    const Stats g = stats(gap_us), f = stats(fcl_us), it = stats(iterations), grad = stats(gradient);
    std::printf("  %-20s %7d | %6.2f %6.2f %6.2f | %6.2f %6.2f %6.2f | %5.2f %5.2f | %5.2f %4.0f %4d | %6d %6d %8.1e %8.1e | %8.1e %8.1e\n",
                name.c_str(), pairs, g.mean, g.median, g.p99, f.mean, f.median, f.p99, g.mean / f.mean,
                g.median / f.median, it.mean, it.max, newton_unconverged, plain_run, plain_unconverged,
                stats(agreement_resolved).max, stats(agreement).max, grad.median, grad.max);
  }
  nlohmann::json json() const {
    return {{"pairs", pairs},
            {"gap_newton_us", to_json(stats(gap_us))},
            {"fcl_us", to_json(stats(fcl_us))},
            {"newton_iterations", to_json(stats(iterations))},
            {"lambda_agreement", to_json(stats(agreement))},
            {"lambda_agreement_resolved", to_json(stats(agreement_resolved))},
            {"fd_run", fd_run},
            {"gradient_failed", gradient_failed},
            {"fd_unconverged", fd_unconverged},
            {"gradient_fd_error", to_json(stats(gradient))},
            {"newton_unconverged", newton_unconverged},
            {"plain_run", plain_run},
            {"plain_unconverged", plain_unconverged}};
  }
};

}  // namespace

// A failing benchmark ends on its uncaught exception (std::terminate prints it).
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  distlab::app::use_huge_page_heap(argv);
  long pairs = 1'000'000, first_pair = 0;
  unsigned long seed = 1;
  int passes = 1, chunk = 4096, plain_every = 1, fd_every = 1;
  unsigned threads = 2;
  std::string csv_path, json_path;
  bool check = false;
  for (int i = 1; i < argc; ++i) {
    auto next = [&] { return i + 1 < argc ? argv[++i] : ""; };
    if (!std::strcmp(argv[i], "--pairs")) pairs = std::atol(next());
    else if (!std::strcmp(argv[i], "--first")) first_pair = std::atol(next());
    else if (!std::strcmp(argv[i], "--seed")) seed = std::strtoul(next(), nullptr, 10);
    else if (!std::strcmp(argv[i], "--passes")) passes = std::atoi(next());
    else if (!std::strcmp(argv[i], "--chunk")) chunk = std::atoi(next());
    else if (!std::strcmp(argv[i], "--plain-every")) plain_every = std::atoi(next());
    else if (!std::strcmp(argv[i], "--fd-every")) fd_every = std::atoi(next());
    else if (!std::strcmp(argv[i], "--threads")) threads = static_cast<unsigned>(std::max(0, std::atoi(next())));
    else if (!std::strcmp(argv[i], "--csv")) csv_path = next();
    else if (!std::strcmp(argv[i], "--json")) json_path = next();
    else if (!std::strcmp(argv[i], "--check")) check = true;
    else pairs = -1;
  }
  if (pairs <= 0 || first_pair < 0 || passes <= 0 || chunk <= 0 || plain_every <= 0 || fd_every <= 0 || threads == 0) {
    std::fprintf(stderr,
                 "usage: %s [--pairs N > 0] [--first F >= 0] [--seed S] [--passes P > 0] [--chunk C > 0] [--plain-every K > 0] "
                 "[--fd-every K > 0] [--threads T > 0] [--csv FILE[.gz]] [--json FILE] [--check]\n",
                 argv[0]);
    return 2;
  }
  CsvOut csv(csv_path);
  if (csv.failed(csv_path)) {
    std::fprintf(stderr, "cannot write --csv %s\n", csv_path.c_str());
    return 2;
  }
  csv.line(
      "pair,kind_a,kind_b,regime,euclidean_distance,fcl_distance,gap_distance,lambda_newton,newton_iterations,"
      "lambda_plain,lambda_agreement,plain_iterations,gradient_fd_error,gap_us,fcl_us\n");
  GapParams newton = paper_params();
  newton.tol = 1e-10, newton.gradient = true;
  Bucket all;
  std::array<Bucket, 3> by_regime;
  std::array<Bucket, 5> by_kind;  // pairs with that kind on either side
  const auto t_start = std::chrono::steady_clock::now();
  const long end = first_pair + pairs;
  for (long first = first_pair; first < end; first += chunk) {
    const size_t n = static_cast<size_t>(std::min<long>(chunk, end - first));
    // Drawing and checking run on `threads` threads; the timed calls run alone, one thread.
    // Pair i draws from its own generator (seed, i): the same pairs for any thread count.
    std::vector<std::optional<Pair>> batch(n);
    parallel_indices(n, threads, [&](size_t i) {
      const long index = first + static_cast<long>(i);
      std::seed_seq seq{static_cast<unsigned long>(seed), static_cast<unsigned long>(index)};
      std::mt19937_64 rng(seq);
      std::uniform_int_distribution<int> kind(0, 4);
      const int ka = kind(rng), kb = kind(rng);
      batch[i].emplace(make_pair(ka, kb, static_cast<Regime>(index % 3), rng));
    });
    std::vector<Row> rows(n);
    for (int pass = 0; pass < passes; ++pass) {
      for (size_t i = 0; i < n; ++i) {
        EuclideanResult e;
        const Pair& p = *batch[i];
        rows[i].fcl_us = std::min(rows[i].fcl_us, time_us(1, [&] {
                                    e = fcl_distance(p.a.euclidean(), p.a.pose(), p.b.euclidean(), p.b.pose());
                                  }));
        rows[i].fcl_distance = e.distance;
      }
      for (size_t i = 0; i < n; ++i) {
        const Pair& p = *batch[i];
        rows[i].gap_us = std::min(rows[i].gap_us, time_us(1, [&] { rows[i].newton = gap_distance(p.a, p.b, newton); }));
      }
    }
    parallel_indices(n, threads, [&](size_t i) {
      Pair& p = *batch[i];
      Row& r = rows[i];
      const long k = (first + static_cast<long>(i)) / 3;  // every K-th pair of each regime
      if (k % plain_every == 0) {
        // The paper's stop rule (step below tol) made relative: tol = 1e-9 D, D from Newton
        // used only as the scale. Near contact D is tiny and the iteration crawls, so many
        // such pairs end unconverged at the cap; their Λ is not compared.
        GapParams plain = paper_params();
        plain.solver = GapSolver::fixed_point, plain.max_iter = kPlainIterations;
        plain.tol = std::clamp(kPlainStep * r.newton.distance, 1e-300, 0.5);
        const GapResult pl = gap_distance(p.a, p.b, plain);
        r.plain_run = true;
        r.lambda_plain = pl.lambda, r.plain_iterations = pl.iterations;
        r.plain_converged = pl.converged && pl.iterations < kPlainIterations;
        const double ln = r.newton.lambda;
        r.agreement = ln > 0 ? std::abs(ln - pl.lambda) / ln : std::abs(pl.lambda);
      }
      if (k % fd_every == 0) r.fd_run = true, r.gradient_error = gradient_error(p, r.newton, r.fd_converged);
    });
    for (size_t i = 0; i < n; ++i) {
      const Pair& p = *batch[i];
      const Row& r = rows[i];
      all.add(r);
      by_regime[static_cast<size_t>(p.regime)].add(r);
      by_kind[static_cast<size_t>(p.kind_a)].add(r);
      if (p.kind_b != p.kind_a) by_kind[static_cast<size_t>(p.kind_b)].add(r);
      // Columns of the checks not run on this pair (--plain-every, --fd-every) stay empty.
      char plain_cols[96] = ",,", fd_col[48] = "";
      if (r.plain_run)
        std::snprintf(plain_cols, sizeof plain_cols, "%.17g,%.3e,%d", r.lambda_plain, r.agreement,
                      r.plain_converged ? r.plain_iterations : -1);
      if (r.fd_run) std::snprintf(fd_col, sizeof fd_col, "%.3e", r.gradient_error);
      char line[512];
      std::snprintf(line, sizeof line, "%ld,%s,%s,%s,%.17g,%.17g,%.17g,%.17g,%d,%s,%s,%.4f,%.4f\n",
                    first + static_cast<long>(i), kKinds[static_cast<size_t>(p.kind_a)],
                    kKinds[static_cast<size_t>(p.kind_b)], kRegimes[static_cast<size_t>(p.regime)], p.euclidean,
                    r.fcl_distance, r.newton.distance, r.newton.lambda, r.newton.iterations, plain_cols, fd_col,
                    r.gap_us, r.fcl_us);
      csv.line(line);
    }
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    const long done = std::min(end, first + chunk) - first_pair;
    std::fprintf(stderr, "\r%ld / %ld pairs, %.0f s, about %.0f s left   ", done, pairs, elapsed,
                 elapsed * static_cast<double>(pairs - done) / static_cast<double>(done));
  }
  std::fprintf(stderr, "\n");
  std::printf(
      "GAP public benchmark: %ld random pairs (5 shape kinds; separated, touching <= 1e-6, overlapping), "
      "seed %lu, fastest of %d cold pass(es), timed on one thread; times in us; plain iteration on every %d-th, "
      "finite differences on every %d-th pair of each regime\n",
      pairs, seed, passes, plain_every, fd_every);
  std::printf("  %-20s %7s | %-20s | %-20s | %-11s | %-14s | %-31s | %s\n", "", "", "GAP Newton, incl start",
              "FCL distance", "GAP/FCL", "Newton it", "plain iteration, Λ agree max", "FD grad err");
  std::printf("  %-20s %7s | %6s %6s %6s | %6s %6s %6s | %5s %5s | %5s %4s %4s | %6s %6s %8s %8s | %8s %8s\n", "pairs",
              "count", "mean", "median", "p99", "mean", "median", "p99", "mean", "med", "mean", "max", "unc",
              "run", "unconv", "D>=1e-4", "all", "median", "max");
  nlohmann::json out{{"pairs", pairs}, {"seed", seed}, {"passes", passes}, {"all", all.json()}};
  for (size_t k = 0; k < 3; ++k) {
    by_regime[k].print(kRegimes[k]);
    out["by_regime"][kRegimes[k]] = by_regime[k].json();
  }
  for (size_t k = 0; k < 5; ++k) {
    by_kind[k].print(std::string("with a ") + kKinds[k]);
    out["by_kind"][kKinds[k]] = by_kind[k].json();
  }
  all.print("all");
  std::printf(
      "  (Λ agree: |Λ_Newton − Λ_plain| / Λ_Newton over the pairs where the plain iteration (step < %.0e D, at most %d steps) converged, bound %.0e; grad err: finite differences of D "
      "and poses in long double, central at 1e-4 d), relative to the largest gradient entry, bound %.0e; asserted by --check, Λ where D >= 1e-4, the gradient on "
      "every pair)\n",
      kPlainStep, kPlainIterations, kAgreementBound, kGradientBound);
  std::printf("  finite differences: %d pairs; %d with a long-double solve unconverged; %d pairs fail\n", all.fd_run,
              all.fd_unconverged, all.gradient_failed);
  if (!json_path.empty()) std::ofstream(json_path) << out.dump(2) << "\n";
  if (check) {
    const double agree = stats(all.agreement_resolved).max;
    if (!(agree <= kAgreementBound) || all.gradient_failed > 0) {
      std::printf("check FAILED: Λ agreement %.2e (bound %.0e), %d pairs' gradient error above %.0e (max %.2e)\n",
                  agree, kAgreementBound, all.gradient_failed, kGradientBound, stats(all.gradient).max);
      return 1;
    }
    std::printf("check passed\n");
  }
  return 0;
}
