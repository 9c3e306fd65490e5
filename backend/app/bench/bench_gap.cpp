// GAP benchmark (issue 2): the paper's Section IV-A experiments, with FCL in the same run.
//   distlab-bench-gap [--pairs N] [--box-pairs N] [--seed S] [--json FILE] [--newton-only]
//   [--boxes-only] [--repeat R] [--passes P] [--save-cases FILE | --load-cases FILE] [--validate N]
//   [--tracking SEQUENCES] [--tracked-only]
// --tracking S: benchmark 3's number of sequences of 100 nearby poses (default 200; 0: none).
// --tracked-only: benchmark 3 alone, FCL and the tracked calls only (no warm calls, no reference
// solve, so no error column), for profiling the tracked path: with --repeat R each step's calls are
// repeated R times (at least 3), so `perf record` sees mostly them.
// --repeat R: each pair is timed R times back to back and the fastest call counts (same for FCL
// and GAP; default 1). That is a warm-cache measure, not the paper's protocol: FCL's second
// call on a pair is about twice as fast as its first (1.2 against 2.4 us), GAP's about 1.7x.
// --passes P: P whole passes over the pairs (benchmarks 1 and 2), the fastest pass per pair counts (cold
// calls every time; only scheduler interruptions drop out). Default 1.
// --newton-only: benchmark 1's FCL and Newton runs alone (no reference, no plain iteration, no
// benchmark 2), for profiling. --boxes-only: benchmark 2 alone (its pairs then differ from the
// full run's; with --newton-only, without the plain iteration). --save-cases/--load-cases FILE:
// benchmark 1's polytope pairs as JSON, so they can be loaded without CGAL (whose interval arithmetic breaks under valgrind):
//   distlab-bench-gap --pairs 2000 --newton-only --save-cases cases.json
//   valgrind --tool=callgrind --toggle-collect='distlab::gap_distance(*' distlab-bench-gap
//     --newton-only --load-cases cases.json     (instructions per pair = total / pairs)
// --validate N: the Property 2 validator on the shapes of benchmark 1's first N pairs (the
// paper's parameters): time of the first call per shape and of a repeated call (answered by the
// verdict cache), the fraction refused, and the GAP Newton solve per pair beside them; nothing else.
// Single thread. GAP times are per pair and include the Euclidean start, as in the paper; the
// start is distlab's double-precision GJK (gjk_distance), timed alone in its own row.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "../src/huge_page_heap.hpp"
#include "distlab/gap/distance.hpp"
#include "distlab/gap/validator.hpp"
#include "distlab/geometry/error.hpp"
#include "gap_cases.hpp"

using namespace distlab;

namespace {

using bench::random_polytope;
using bench::random_rotation;
using bench::random_unit;
using bench::Stats;
using bench::stats;
using bench::to_json;

struct Run {
  std::vector<double> us, iterations, rel_error;
  int not_converged = 0;
};

struct Case {
  GapBody a, b;
};

// Calls per pair; the fastest counts (--repeat; warm cache after the first call).
int g_repeat = 1;
// Whole passes over the pairs; per pair the fastest pass counts (--passes). Every pass meets a
// pair cold (the other 50,000 pairs have evicted it), so this keeps the paper's cold-call
// protocol and only drops the calls that the shared machine's scheduler interrupted.
int g_passes = 1;

// `run` once per pass; times are per-pair minima over the passes, the rest (identical in every
// pass) from the first.
template <class F>
auto best_of_passes(F&& run) {
  auto best = run();
  for (int p = 1; p < g_passes; ++p) {
    const auto next = run();
    for (size_t i = 0; i < best.us.size(); ++i) best.us[i] = std::min(best.us[i], next.us[i]);
  }
  return best;
}

template <class F>
double time_us(F&& f) {
  return bench::time_us(g_repeat, f);
}

// Thread CPU time: this machine is shared, and wall time then mostly measures the others.
template <class F>
double thread_cpu_us(F&& f) {
  timespec t0, t1;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t0);
  f();
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t1);
  return 1e6 * double(t1.tv_sec - t0.tv_sec) + 1e-3 * double(t1.tv_nsec - t0.tv_nsec);
}

// One pass over all pairs timed as a whole (no per-pair clock), the fastest of --passes, per pair:
// what a batched caller (the Python binding's loop) is compared with.
double batch_cpu_us_per_pair(std::vector<Case>& cases, const GapParams& params) {
  double best = INFINITY, sink = 0;
  for (int p = 0; p < g_passes; ++p)
    best = std::min(best, thread_cpu_us([&] {
                      for (Case& c : cases) sink += gap_distance(c.a, c.b, params).lambda;
                    }));
  if (!std::isfinite(sink)) std::fprintf(stderr, "non-finite Λ in the batch pass\n");
  return best / double(cases.size());
}

// gap_distance_batch over all pairs on `threads` threads, wall time of the fastest of --passes
// passes, per pair: the batched throughput (the machine must have the cores free to show it).
double batch_wall_us_per_pair(std::vector<Case>& cases, const GapParams& params, unsigned threads) {
  std::vector<std::pair<const GapBody*, const GapBody*>> pairs;
  pairs.reserve(cases.size());
  for (Case& c : cases) pairs.emplace_back(&c.a, &c.b);
  double best = INFINITY, sink = 0;
  for (int p = 0; p < g_passes; ++p)
    best = std::min(best, bench::time_us(1, [&] { sink += gap_distance_batch(pairs, params, threads).back().lambda; }));
  if (!std::isfinite(sink)) std::fprintf(stderr, "non-finite Λ in the batch pass\n");
  return best / double(cases.size());
}

void print_row(const char* name, const Run& r) {
  const Stats t = stats(r.us), it = stats(r.iterations), err = stats(r.rel_error);
  std::printf("  %-30s %8.2f %8.2f %8.2f %9.2f | %7.2f %7.0f %7.0f | %9.2e %9.2e %6d\n", name,
              t.mean, t.median, t.p99, t.max, it.mean, it.p99, it.max, err.median, err.max,
              r.not_converged);
}

nlohmann::json run_json(const Run& r) {
  return {{"time_us", to_json(stats(r.us))},
          {"iterations", to_json(stats(r.iterations))},
          {"relative_error_of_D", to_json(stats(r.rel_error))},
          {"not_converged", r.not_converged}};
}

// Runs GAP with `params` on every case, timing start + solver; relative error of D against a
// reference solved to 1e-13 with Newton.
Run run_gap(std::vector<Case>& cases, const GapParams& params, const std::vector<double>& ref) {
  Run r;
  for (size_t i = 0; i < cases.size(); ++i) {
    GapResult res;
    r.us.push_back(time_us([&] { res = gap_distance(cases[i].a, cases[i].b, params); }));
    r.iterations.push_back(res.iterations);
    if (!res.converged) ++r.not_converged;
    if (!ref.empty()) r.rel_error.push_back(std::abs(res.distance - ref[i]) / ref[i]);
  }
  return r;
}

// FCL's distance call alone (`certified`: our duality-gap-checked wrapper instead).
Run run_fcl(std::vector<Case>& cases, bool certified = false) {
  Run r;
  for (auto& c : cases) {
    EuclideanResult e;
    r.us.push_back(time_us([&] {
      e = certified ? euclidean_distance(c.a.euclidean(), c.a.pose(), c.b.euclidean(), c.b.pose())
                    : fcl_distance(c.a.euclidean(), c.a.pose(), c.b.euclidean(), c.b.pose());
    }));
    r.iterations.push_back(0);
  }
  return r;
}

// The GAP solver's Euclidean start alone (gjk_distance, uncertified double GJK, as gap_distance stops it).
Run run_start(std::vector<Case>& cases) {
  Run r;
  for (auto& c : cases) {
    EuclideanResult e;
    r.us.push_back(time_us([&] {
      e = gjk_distance(c.a.p2s().shape(), c.a.pose(), c.b.p2s().shape(), c.b.pose(),
                       c.a.radius() + c.b.radius(), kStartRelativeGap);
    }));
    r.iterations.push_back(0);
  }
  return r;
}

std::vector<double> reference(std::vector<Case>& cases, GapParams params) {
  params.solver = GapSolver::newton;
  params.tol = 1e-13;
  params.gradient = false;
  params.euclidean = true;  // certified start, independent of the timed path
  std::vector<double> d;
  d.reserve(cases.size());
  for (auto& c : cases) d.push_back(gap_distance(c.a, c.b, params).distance);
  return d;
}

const char* kHeader =
    "  %-30s %8s %8s %8s %9s | %7s %7s %7s | %9s %9s %6s\n";

// Benchmark 3, tracking (a control loop): `sequences` pairs of benchmark 1, B moved `steps`
// times by at most 1 mm and 1 degree; GAP warm-started from the previous step's witnesses
// (gap_distance_warm, with gradients) against FCL's cold call on the same poses, interleaved step
// by step, and gap_distance_tracked (the start predicted from the last solution and the pose
// change); each step's time is the fastest of 3 back-to-back calls for all (the control loop's
// cache is warm anyway; this drops the shared machine's interruptions). Relative error of D
// against a cold solve at tol 1e-13.
struct Tracking {
  Run fcl, warm, tracked;
};

Tracking run_tracking(const std::vector<Case>& cases, GapParams params, int sequences, int steps,
                      std::mt19937_64& rng, bool tracked_only = false) {
  params.gradient = true;
  GapParams ref = params;
  ref.tol = 1e-13, ref.euclidean = true;
  std::uniform_real_distribution<double> unit(0, 1);
  Tracking t;
  for (int q = 0; q < std::min<int>(sequences, static_cast<int>(cases.size())); ++q) {
    Case c = cases[static_cast<size_t>(q)];
    GapResult prev = gap_distance(c.a, c.b, params);
    GapTrack track;  // primed at the first pose: a cold call, then one with derivatives kept
    for (int k = 0; k < 2; ++k) gap_distance_tracked(c.a, c.b, params, track);
    Pose pose = c.b.pose();
    for (int k = 0; k < steps; ++k) {
      pose.position += random_unit(rng) * (1e-3 * unit(rng));
      pose.rotation = (Quat(Eigen::AngleAxisd(unit(rng) * M_PI / 180, random_unit(rng))) * pose.rotation)
                          .normalized();
      c.b.set_pose(pose);
      EuclideanResult e;
      GapResult w;
      const int repeat = g_repeat;
      g_repeat = std::max(repeat, 3);
      t.fcl.us.push_back(time_us([&] { e = fcl_distance(c.a.euclidean(), c.a.pose(), c.b.euclidean(), pose); }));
      t.fcl.iterations.push_back(0);
      if (!tracked_only)
        t.warm.us.push_back(time_us([&] { w = gap_distance_warm(c.a, c.b, params, prev.witness_a, prev.witness_b); }));
      g_repeat = repeat;
      // The tracked call updates its state: each repeat starts from a copy made outside the clock.
      GapResult tr;
      GapTrack next;
      double best = INFINITY;
      for (int rep = 0; rep < std::max(repeat, 3); ++rep) {
        next = track;
        // One call per copy, whatever --repeat says: a second call would find nothing moved.
        best = std::min(best, bench::time_us(1, [&] { tr = gap_distance_tracked(c.a, c.b, params, next); }));
      }
      track = next;
      t.tracked.us.push_back(best);
      t.tracked.iterations.push_back(tr.iterations);
      if (!tr.converged) ++t.tracked.not_converged;
      if (tracked_only) continue;
      t.warm.iterations.push_back(w.iterations);
      if (!w.converged) ++t.warm.not_converged;
      const double d = gap_distance(c.a, c.b, ref).distance;
      t.warm.rel_error.push_back(d > 0 ? std::abs(w.distance - d) / d : std::abs(w.distance));
      t.tracked.rel_error.push_back(d > 0 ? std::abs(tr.distance - d) / d : std::abs(tr.distance));
      prev = w;
    }
  }
  return t;
}

void print_tracking(const Tracking& t, int sequences, int steps, nlohmann::json& out) {
  if (sequences <= 0 || steps <= 0) return;  // --tracking 0: no table (its ratios would be 0/0)
  std::printf(
      "GAP benchmark 3, tracking: %d sequences of %d steps (<= 1 mm, <= 1 deg each) of benchmark 1's "
      "pairs, single thread (times in us)\n",
      sequences, steps);
  std::printf(kHeader, "method", "mean", "median", "p99", "max", "it mean", "it p99", "it max",
              "err med", "err max", "unconv");
  print_row("FCL distance, cold", t.fcl);
  const bool warm = !t.warm.us.empty();  // empty with --tracked-only
  if (warm) print_row("GAP Newton warm, tol 1e-10", t.warm);
  print_row("GAP Newton tracked (predicted)", t.tracked);
  const double tracked_ratio = stats(t.tracked.us).mean / stats(t.fcl.us).mean;
  const double tracked_median = stats(t.tracked.us).median / stats(t.fcl.us).median;
  out["tracking"] = {{"sequences", sequences}, {"steps", steps}, {"repeat", std::max(g_repeat, 3)}, {"fcl", run_json(t.fcl)}, {"newton_tracked_tol_1e-10", run_json(t.tracked)}, {"tracked_over_fcl_mean", tracked_ratio}, {"tracked_over_fcl_median", tracked_median}};
  if (!warm) {
    std::printf("  tracked GAP/FCL: mean %.2f, median %.2f (no error column: no reference solve)\n\n", tracked_ratio,
                tracked_median);
    return;
  }
  const double ratio = stats(t.warm.us).mean / stats(t.fcl.us).mean;
  const double ratio_median = stats(t.warm.us).median / stats(t.fcl.us).median;
  std::printf("  warm GAP/FCL time ratio: mean %.2f, median %.2f; tracked GAP/FCL: mean %.2f, median %.2f\n\n",
              ratio, ratio_median, tracked_ratio, tracked_median);
  out["tracking"]["newton_warm_tol_1e-10"] = run_json(t.warm);
  out["tracking"]["warm_over_fcl_mean"] = ratio;
  out["tracking"]["warm_over_fcl_median"] = ratio_median;
}

// A pair of benchmark 1 as stored by --save-cases.
struct PolytopePair {
  Polytope a, b;
  Pose pose_a, pose_b;
};

nlohmann::json polytope_json(const Polytope& p, const Pose& pose) {
  nlohmann::json j;
  for (int i = 0; i < p.rows(); ++i) j["A"].push_back({p.A(i, 0), p.A(i, 1), p.A(i, 2)});
  j["b"] = std::vector<double>(p.b.data(), p.b.data() + p.b.size());
  for (const auto& v : p.vertices) j["vertices"].push_back({v.x(), v.y(), v.z()});
  for (const auto& f : p.faces) j["faces"].push_back({f.x(), f.y(), f.z()});
  const Vec3& t = pose.position;
  const Quat& q = pose.rotation;
  j["position"] = {t.x(), t.y(), t.z()};
  j["quaternion"] = {q.w(), q.x(), q.y(), q.z()};
  return j;
}

// Read back exactly as written (the vertices and faces are FCL's geometry, so no hull is taken).
std::pair<Polytope, Pose> polytope_from_json(const nlohmann::json& j) {
  Polytope p;
  const auto& A = j.at("A");
  p.A.resize(static_cast<Eigen::Index>(A.size()), 3);
  p.b.resize(static_cast<Eigen::Index>(A.size()));
  for (size_t i = 0; i < A.size(); ++i) {
    for (int c = 0; c < 3; ++c) p.A(static_cast<Eigen::Index>(i), c) = A[i][c].get<double>();
    p.b[static_cast<Eigen::Index>(i)] = j.at("b")[i].get<double>();
  }
  for (const auto& v : j.at("vertices")) p.vertices.emplace_back(v[0], v[1], v[2]);
  for (const auto& f : j.at("faces")) p.faces.emplace_back(f[0], f[1], f[2]);
  const auto& t = j.at("position");
  const auto& q = j.at("quaternion");
  return {p, Pose{Vec3(t[0], t[1], t[2]), Quat(q[0], q[1], q[2], q[3])}};
}

// Benchmark 2: boxes and cylinders, h from 0.01 to 0.08; the same pairs for GAP and FCL (the
// plain iteration too unless `newton_only`).
void run_boxes(int box_pairs, const GapParams& paper, bool newton_only, std::mt19937_64& rng, nlohmann::json& out) {
  std::printf("GAP benchmark 2: %d box/cylinder pairs, h = 0.01 .. 0.08 (times in us, GAP's incl. its start)\n",
              box_pairs);
  std::printf("  %-6s %-22s %-22s %-22s %9s %6s\n", "h", "FCL mean +- sd", "GAP plain 1e-3", "GAP Newton 1e-10",
              "Newton/FCL", "unconv");
  nlohmann::json by_h = nlohmann::json::array();
  std::uniform_real_distribution<double> pos(-0.5, 0.5), size(0.05, 0.4);
  Run all_fcl, all_plain, all_newton;
  for (int hi = 1; hi <= 8; ++hi) {
    GapParams p = paper;
    p.h = 0.01 * hi;
    std::vector<Case> bc;
    while (static_cast<int>(bc.size()) < box_pairs / 8) {
      auto shape = [&](int kind) -> Shape {
        if (kind == 0) return Box{Vec3(size(rng), size(rng), size(rng))};
        return Cylinder{size(rng) / 2, size(rng)};
      };
      Case c{GapBody(shape(bc.size() % 2), Pose{Vec3::Zero(), random_rotation(rng)}, p),
             GapBody(shape((bc.size() / 2) % 2), Pose{Vec3(pos(rng), pos(rng), pos(rng)) * 1.5, random_rotation(rng)}, p)};
      const auto e = euclidean_distance(c.a.euclidean(), c.a.pose(), c.b.euclidean(), c.b.pose());
      if (e.distance >= 0.05) bc.push_back(std::move(c));
    }
    GapParams pp = p, pn = p;
    pp.solver = GapSolver::fixed_point, pp.tol = 1e-3, pp.max_iter = 100000;
    pn.solver = GapSolver::newton, pn.tol = 1e-10;
    const Run f = best_of_passes([&] { return run_fcl(bc); });
    const Run rp = newton_only ? Run{} : best_of_passes([&] { return run_gap(bc, pp, {}); });
    const Run rn = best_of_passes([&] { return run_gap(bc, pn, {}); });
    const Stats sf = stats(f.us), sp = stats(rp.us), sn = stats(rn.us);
    std::printf("  %-6.2f %8.2f +- %-10.2f %8.2f +- %-10.2f %8.2f +- %-10.2f %9.2f %6d\n", p.h, sf.mean,
                sf.stddev, sp.mean, sp.stddev, sn.mean, sn.stddev, sn.mean / sf.mean,
                rn.not_converged + rp.not_converged);
    by_h.push_back({{"h", p.h}, {"fcl", run_json(f)}, {"newton_tol_1e-10", run_json(rn)}});
    if (!newton_only) by_h.back()["plain_tol_1e-3"] = run_json(rp);
    all_fcl.us.insert(all_fcl.us.end(), f.us.begin(), f.us.end());
    all_plain.us.insert(all_plain.us.end(), rp.us.begin(), rp.us.end());
    all_newton.us.insert(all_newton.us.end(), rn.us.begin(), rn.us.end());
  }
  const Stats af = stats(all_fcl.us), ap = stats(all_plain.us), an = stats(all_newton.us);
  std::printf("  %-6s %8.2f +- %-10.2f %8.2f +- %-10.2f %8.2f +- %-10.2f %9.2f\n", "all", af.mean, af.stddev,
              ap.mean, ap.stddev, an.mean, an.stddev, an.mean / af.mean);
  std::printf("  (paper: GAP 40 +- 31 us, Euclidean 29 +- 4 us)\n");
  out["boxes_cylinders"] = {{"pairs", box_pairs}, {"by_h", by_h}, {"all", {{"fcl", to_json(af)}, {"newton_tol_1e-10", to_json(an)}, {"newton_over_fcl_mean", an.mean / af.mean}}}};
  if (!newton_only) out["boxes_cylinders"]["all"]["plain_tol_1e-3"] = to_json(ap);
}

}  // namespace

// A failing benchmark ends on its uncaught exception (std::terminate prints it).
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  distlab::app::use_huge_page_heap(argv);
  int pairs = 50000, box_pairs = 40000;
  unsigned long seed = 1;
  std::string json_path;
  bool newton_only = false, boxes_only = false, tracked_only = false;
  std::string save_path, load_path;
  int validate_pairs = 0;
  int tracking_sequences = 200, tracking_steps = 100;
  for (int i = 1; i < argc; ++i) {
    auto next = [&] { return i + 1 < argc ? argv[++i] : ""; };
    if (!std::strcmp(argv[i], "--pairs")) pairs = std::atoi(next());
    else if (!std::strcmp(argv[i], "--box-pairs")) box_pairs = std::atoi(next());
    else if (!std::strcmp(argv[i], "--seed")) seed = std::strtoul(next(), nullptr, 10);
    else if (!std::strcmp(argv[i], "--json")) json_path = next();
    else if (!std::strcmp(argv[i], "--newton-only")) newton_only = true;
    else if (!std::strcmp(argv[i], "--boxes-only")) boxes_only = true;
    else if (!std::strcmp(argv[i], "--repeat")) g_repeat = std::max(1, std::atoi(next()));
    else if (!std::strcmp(argv[i], "--passes")) g_passes = std::max(1, std::atoi(next()));
    else if (!std::strcmp(argv[i], "--save-cases")) save_path = next();
    else if (!std::strcmp(argv[i], "--load-cases")) load_path = next();
    else if (!std::strcmp(argv[i], "--validate")) validate_pairs = std::max(1, std::atoi(next()));
    else if (!std::strcmp(argv[i], "--tracking")) tracking_sequences = std::max(0, std::atoi(next()));
    else if (!std::strcmp(argv[i], "--tracked-only")) tracked_only = true;
    else {
      std::fprintf(stderr, "usage: %s [--pairs N] [--box-pairs N] [--seed S] [--json FILE] [--newton-only] [--boxes-only] [--repeat R] [--passes P] [--save-cases FILE | --load-cases FILE] [--validate N] [--tracking SEQUENCES] [--tracked-only]\n", argv[0]);
      return 2;
    }
  }
  nlohmann::json out;
  std::mt19937_64 rng(seed);

  // 1. The paper's experiment: 10-half-space polytopes, true distance >= 5 cm, k = 2, h = 0.1,
  // W_i = 1/6, eps = 0.01, sigma = 0.989; the plain iteration stops at ||a[k+1] − a[k]|| < 1e-3.
  const GapParams paper = bench::paper_params();
  if (boxes_only) {
    run_boxes(box_pairs, paper, newton_only, rng, out);
    if (!json_path.empty()) std::ofstream(json_path) << out.dump(2) << "\n";
    return 0;
  }
  const P2SOptions sixth = bench::paper_polytope_options();
  std::vector<Case> cases;
  std::uniform_real_distribution<double> pos(-0.5, 0.5);
  if (!load_path.empty()) {
    std::ifstream in(load_path);
    if (!in) {
      std::fprintf(stderr, "cannot read %s\n", load_path.c_str());
      return 2;
    }
    for (const auto& j : nlohmann::json::parse(in)) {
      auto [pa, pose_a] = polytope_from_json(j.at("a"));
      auto [pb, pose_b] = polytope_from_json(j.at("b"));
      cases.push_back(Case{GapBody(pa, pose_a, paper, sixth), GapBody(pb, pose_b, paper, sixth)});
    }
    pairs = static_cast<int>(cases.size());
  }
  nlohmann::json saved = nlohmann::json::array();
  while (static_cast<int>(cases.size()) < pairs) {
    // Draw order kept from earlier versions (same pairs for the same seed).
    PolytopePair pp;
    pp.a = random_polytope(rng);
    pp.pose_a = Pose{Vec3::Zero(), random_rotation(rng)};
    pp.b = random_polytope(rng);
    pp.pose_b = Pose{Vec3(pos(rng), pos(rng), pos(rng)), random_rotation(rng)};
    Case c{GapBody(pp.a, pp.pose_a, paper, sixth), GapBody(pp.b, pp.pose_b, paper, sixth)};
    const auto e = euclidean_distance(c.a.euclidean(), c.a.pose(), c.b.euclidean(), c.b.pose());
    if (e.distance < 0.05) continue;
    cases.push_back(std::move(c));
    if (!save_path.empty())
      saved.push_back({{"a", polytope_json(pp.a, pp.pose_a)}, {"b", polytope_json(pp.b, pp.pose_b)}});
  }
  if (!save_path.empty()) std::ofstream(save_path) << saved.dump() << "\n";
  GapParams plain = paper;
  plain.solver = GapSolver::fixed_point, plain.tol = 1e-3, plain.max_iter = 100000;
  GapParams newton = paper;
  newton.solver = GapSolver::newton, newton.tol = 1e-10;
  GapParams plain_tight = plain;
  plain_tight.tol = 1e-10;
  if (tracked_only) {
    nlohmann::json j{{"pairs", pairs}};
    print_tracking(run_tracking(cases, newton, tracking_sequences, tracking_steps, rng, true), tracking_sequences,
                   tracking_steps, j);
    if (!json_path.empty()) std::ofstream(json_path) << j.dump(2) << "\n";
    return 0;
  }
  if (validate_pairs > 0) {
    const std::size_t n = std::min<std::size_t>(static_cast<std::size_t>(validate_pairs), cases.size());
    Run first, again, solve;
    int refused = 0;
    double worst = 0;
    for (std::size_t i = 0; i < 2 * n; ++i) {
      const GapBody& body = i % 2 ? cases[i / 2].b : cases[i / 2].a;
      ValidationReport rep;
      first.us.push_back(thread_cpu_us([&] { rep = validate_p2s(body.p2s()); }));
      // A repeated shape: 100 calls per measure (a single one is below the clock's resolution).
      again.us.push_back(thread_cpu_us([&] {
                           for (int k = 0; k < 100; ++k) validate_p2s(body.p2s());
                         }) /
                         100);
      if (!rep.ok) ++refused;
      worst = std::max(worst, rep.max_eigenvalue);
    }
    for (std::size_t i = 0; i < n; ++i)
      solve.us.push_back(thread_cpu_us([&] {
                           for (int k = 0; k < 100; ++k) gap_distance(cases[i].a, cases[i].b, newton);
                         }) /
                         100);
    std::printf(
        "Property 2 validation of %zu shapes (benchmark 1's first %zu pairs, eps %g, sigma %g, "
        "W_i = 1/6), single thread, thread CPU time in us\n",
        2 * n, n, paper.eps, paper.sigma);
    std::printf(kHeader, "method", "mean", "median", "p99", "max", "", "", "", "", "", "");
    print_row("validate, first call per shape", first);
    print_row("validate, repeated shape", again);
    print_row("GAP Newton solve per pair", solve);
    std::printf("  refused: %d of %zu shapes (%.1f%%); largest eigenvalue found %.4g\n", refused, 2 * n,
                100.0 * refused / (2 * n), worst);
    if (!json_path.empty())
      std::ofstream(json_path) << nlohmann::json{{"shapes", 2 * n},
                                                 {"refused", refused},
                                                 {"refused_fraction", double(refused) / (2 * n)},
                                                 {"largest_eigenvalue", worst},
                                                 {"validate_first_us", to_json(stats(first.us))},
                                                 {"validate_repeated_us", to_json(stats(again.us))},
                                                 {"newton_solve_us", to_json(stats(solve.us))}}
                                      .dump(2)
                               << "\n";
    return 0;
  }
  if (newton_only) {
    const Run fcl = best_of_passes([&] { return run_fcl(cases); });
    const Run start = best_of_passes([&] { return run_start(cases); });
    const Run r_newton = best_of_passes([&] { return run_gap(cases, newton, {}); });
    std::printf(kHeader, "method", "mean", "median", "p99", "max", "it mean", "it p99", "it max",
                "err med", "err max", "unconv");
    print_row("FCL distance alone", fcl);
    print_row("GAP's start alone (double GJK)", start);
    print_row("GAP Newton, tol 1e-10", r_newton);
    std::printf("  Newton/FCL time ratio: mean %.2f, median %.2f\n",
                stats(r_newton.us).mean / stats(fcl.us).mean,
                stats(r_newton.us).median / stats(fcl.us).median);
    const double batch = batch_cpu_us_per_pair(cases, newton);
    std::printf("  GAP Newton, whole pass timed as one (thread CPU, fastest of %d passes): %.3f us per pair\n",
                g_passes, batch);
    const double batch1 = batch_wall_us_per_pair(cases, newton, 1), batch2 = batch_wall_us_per_pair(cases, newton, 2);
    std::printf("  gap_distance_batch (wall, fastest of %d passes): 1 thread %.3f, 2 threads %.3f us per pair; speed-up %.2f\n\n",
                g_passes, batch1, batch2, batch1 / batch2);
    nlohmann::json j{{"pairs", pairs}, {"repeat", g_repeat}, {"passes", g_passes}, {"fcl", run_json(fcl)}, {"start_gjk", run_json(start)}, {"newton_tol_1e-10", run_json(r_newton)}, {"newton_batch_cpu_us_per_pair", batch}, {"batch_wall_us_per_pair_1_thread", batch1}, {"batch_wall_us_per_pair_2_threads", batch2}};
    print_tracking(run_tracking(cases, newton, tracking_sequences, tracking_steps, rng),
                   tracking_sequences, tracking_steps, j);
    if (!json_path.empty()) std::ofstream(json_path) << j.dump(2) << "\n";
    return 0;
  }
  const std::vector<double> ref = reference(cases, paper);
  const Run fcl = best_of_passes([&] { return run_fcl(cases); });
  const Run fcl_certified = best_of_passes([&] { return run_fcl(cases, true); });
  const Run start = best_of_passes([&] { return run_start(cases); });
  const Run r_plain = best_of_passes([&] { return run_gap(cases, plain, ref); });
  const Run r_newton = best_of_passes([&] { return run_gap(cases, newton, ref); });
  // The plain iteration at 1e-10 crawls (up to 1e5 steps near contact): a subset suffices.
  std::vector<Case> subset(cases.begin(), cases.begin() + std::min<size_t>(cases.size(), 5000));
  const Run r_tight = run_gap(subset, plain_tight, ref);
  std::printf(
      "GAP benchmark 1: %d random pairs of 10-half-space polytopes, distance >= 5 cm, "
      "single thread (times in us; GAP's include its Euclidean start)\n",
      pairs);
  std::printf(kHeader, "method", "mean", "median", "p99", "max", "it mean", "it p99", "it max",
              "err med", "err max", "unconv");
  print_row("FCL distance alone", fcl);
  print_row("Euclidean, certified (distlab)", fcl_certified);
  print_row("GAP's start alone (double GJK)", start);
  print_row("GAP plain iteration, tol 1e-3", r_plain);
  print_row("GAP plain, tol 1e-10 (5000 pairs)", r_tight);
  print_row("GAP Newton, tol 1e-10", r_newton);
  const double ratio = stats(r_newton.us).mean / stats(fcl.us).mean;
  const double ratio_median = stats(r_newton.us).median / stats(fcl.us).median;
  std::printf("  Newton/FCL time ratio: mean %.2f, median %.2f; plain(1e-3)/Newton mean: %.2f\n",
              ratio, ratio_median, stats(r_plain.us).mean / stats(r_newton.us).mean);
  std::printf(
      "  (err: relative error of D against Newton at tol 1e-13; paper: mean 70 us, max 200 us, "
      "mean 22.42 and max 295 iterations)\n\n");
  out["repeat"] = g_repeat;
  out["passes"] = g_passes;
  out["polytopes"] = {{"pairs", pairs},
                      {"fcl", run_json(fcl)},
                      {"euclidean_certified", run_json(fcl_certified)},
                      {"start_gjk", run_json(start)},
                      {"plain_tol_1e-3", run_json(r_plain)},
                      {"plain_tol_1e-10", run_json(r_tight)},
                      {"newton_tol_1e-10", run_json(r_newton)},
                      {"newton_over_fcl_mean", ratio},
                      {"newton_over_fcl_median", ratio_median}};

  print_tracking(run_tracking(cases, newton, tracking_sequences, tracking_steps, rng),
                 tracking_sequences, tracking_steps, out);

  run_boxes(box_pairs, paper, false, rng, out);
  if (!json_path.empty()) std::ofstream(json_path) << out.dump(2) << "\n";
  return 0;
}
