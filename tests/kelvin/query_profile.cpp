// distlab-kelvin-query-profile: hint-less and hinted query times on the unit cube of Table I,
// with a fingerprint of the answers, without the rest of the benchmark (solves, SparseLU, RMSE);
// --grading G meshes with that sizing (PrepareOptions::grading; 0 is the paper's); without it
// prepare chooses (the grading column).
// usage: distlab-kelvin-query-profile --cache-dir DIR [--lx 0.05,0.02] [--rounds 5] [--n 100000] [--grading G]
//                                     [--only-seeded 1 (one pass over the bench's 1000 points,
//                                      for callgrind --toggle-collect)] [--dump FILE (every answer
//                                      of the fingerprint, one line each, to diff two builds)]
// The bench's 1000 random points (same generator) are timed one query at a time, as
// bench_kelvin does, in `rounds` passes; before each pass the caches are flushed by streaming a
// buffer larger than the L3 (the bench queries right after its solves have done the same), so
// every pass sees cold caches like the bench's single pass; the medians of all passes' times
// are reported. "AABB med": CGAL's AABB-tree distance to the surface (SurfaceOracle, the baseline
// of distlab-bench-kelvin) at the same 1000 points, timed the same way, caches flushed before
// each pass; "q_seed / AABB" their ratio. "fingerprint" is an FNV-1a
// hash of the bits of h and ∇h at the 1000 points and at n more random points (hint-less), and
// of h and ∇h along the bench's coherent path (hinted): two builds answer bit for bit alike iff
// their fingerprints match. Uses only the public API, so it builds against older versions too.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "../../backend/app/bench/query_sets.hpp"
#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/surface_tools.hpp"
#include "distlab/mesh/primitives.hpp"
#include "profile_args.hpp"

using namespace distlab;
using namespace distlab::kelvin;
using Clock = std::chrono::steady_clock;

namespace {

struct Fnv64 {
  std::uint64_t h = 1469598103934665603ull;
  std::FILE* dump = nullptr;
  void add(double d) {
    unsigned char b[8];
    std::memcpy(b, &d, 8);
    for (unsigned char c : b) h = (h ^ c) * 1099511628211ull;
  }
  void add(const Sample& s) {
    if (dump)
      std::fprintf(dump, "%a %a %a %a %d\n", s.h, s.gradient[0], s.gradient[1], s.gradient[2], static_cast<int>(s.status));
    add(s.h);
    for (int k = 0; k < 3; ++k) add(s.gradient[k]);
    add(static_cast<double>(s.status));
  }
};

double percentile(std::vector<double> v, double q) {
  const auto k = static_cast<long>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<size_t>(k)];
}

// Evicts the caches (and most TLB entries): writes and reads a 256 MB buffer.
double flush_caches() {
  static std::vector<double> junk(std::size_t{32} << 20, 1.0);
  double sum = 0;
  for (double& d : junk) sum += (d += 1.0);
  return sum;
}

double since_us(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count() * 1e6; }

}  // namespace

int main(int argc, char** argv) {
  std::vector<double> lxs = {0.05, 0.02};
  std::string cache_dir;
  int rounds = 5;
  long n_more = 100000;
  bool only_seeded = false;
  std::string dump_path;
  std::optional<double> grading;  // PrepareOptions::grading (not given: prepare chooses)
  if (const int code = kelvin_profile::parse_profile_args(
          argc, argv,
          "usage: distlab-kelvin-query-profile --cache-dir DIR [--lx 0.05,0.02] [--rounds 5] [--n 100000] "
          "[--only-seeded 1] [--grading G]",
          cache_dir, lxs,
          {{"--rounds", [&](const std::string& v) { rounds = std::max(1, std::stoi(v)); }},
           {"--n", [&](const std::string& v) { n_more = std::max(0L, std::stol(v)); }},
           {"--only-seeded", [&](const std::string& v) { only_seeded = v != "0"; }},
           {"--dump", [&](const std::string& v) { dump_path = v; }},
           {"--grading", [&](const std::string& v) { grading = std::stod(v); }}});
      code >= 0)
    return code;
  std::filesystem::create_directories(cache_dir);
  // The bench's query sets (bench_kelvin.cpp): a coherent path and 1000 random points.
  const auto [path, random] = bench::kelvin_query_sets();
  std::vector<Vec3> more;
  std::mt19937 rng2(7);
  std::uniform_real_distribution<double> u(-3, 3);
  while (static_cast<long>(more.size()) < n_more) {
    const Vec3 x(u(rng2), u(rng2), u(rng2));
    if (x.cwiseAbs().maxCoeff() > 0.5) more.push_back(x);
  }

  const mesh::SurfaceMesh cube = mesh::box(Vec3::Ones());
  if (!only_seeded)
    std::printf(
        "| l_x | grading | N_verts | N_tets | size_mb | q_hint med | q_seed med | q_seed p90 | q_seed med (n more) | AABB med | "
        "q_seed / AABB | fingerprint |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  const SurfaceOracle aabb(cube);
  for (double lx : lxs) {
    PrepareOptions o;
    o.lx = lx;
    o.grading = grading;
    Field f = Field::prepare_cached(cube, o, cache_dir);
    f.set_sigma(SigmaSpec{}, true);
    double sink = 0;
    if (only_seeded) {
      for (const Vec3& x : random) sink += f.query(x).h;
      std::printf("l_x %g: sum h %.17g\n", lx, sink);
      continue;
    }
    Fnv64 print;
    if (!dump_path.empty()) print.dump = std::fopen((dump_path + "-" + std::to_string(lx)).c_str(), "w");
    std::vector<double> hinted, seeded, seeded_more, aabb_times;
    std::mt19937 shuffle(11);
    for (int r = 0; r < rounds; ++r) {
      int hint = -1;
      for (const Vec3& x : path) {
        const auto t0 = Clock::now();
        const Sample s = f.query(x, &hint);
        hinted.push_back(since_us(t0));
        if (r == 0) print.add(s);
      }
      std::vector<int> order(random.size());
      for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
      if (r > 0) std::shuffle(order.begin(), order.end(), shuffle);
      std::vector<Sample> answers(random.size());
      sink += flush_caches();
      for (int i : order) {
        const auto t0 = Clock::now();
        answers[static_cast<size_t>(i)] = f.query(random[static_cast<size_t>(i)]);
        seeded.push_back(since_us(t0));
      }
      if (r == 0)
        for (const Sample& s : answers) print.add(s);
      sink += flush_caches();
      for (int i : order) {
        const auto t0 = Clock::now();
        sink += aabb.distance(random[static_cast<size_t>(i)]);
        aabb_times.push_back(since_us(t0));
      }
    }
    sink += flush_caches();
    for (const Vec3& x : more) {  // each once: a larger sample (later ones meet warmer caches)
      const auto t0 = Clock::now();
      const Sample s = f.query(x);
      seeded_more.push_back(since_us(t0));
      print.add(s);
      sink += s.h;
    }
    if (print.dump) std::fclose(print.dump);
    const Stats& st = f.stats();
    std::printf("| %g | %g | %ld | %ld | %.1f | %.3f | %.3f | %.3f | %.3f | %.3f | %.2f | %016llx |\n", lx, st.grading, st.n_verts, st.n_tets,
                st.size_mb, percentile(hinted, 0.5), percentile(seeded, 0.5), percentile(seeded, 0.9),
                seeded_more.empty() ? 0.0 : percentile(seeded_more, 0.5), percentile(aabb_times, 0.5),
                percentile(seeded, 0.5) / percentile(aabb_times, 0.5), static_cast<unsigned long long>(print.h));
    std::fflush(stdout);
    if (sink == 12345.678) std::puts("");
  }
  return 0;
}
