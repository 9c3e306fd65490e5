#pragma once
// Shared by the GAP benchmarks (distlab-bench-gap, distlab-bench-pairs): summary statistics,
// random poses and shapes, the paper's parameters and the timer, so both time the same way.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <random>
#include <vector>

#include "distlab/gap/distance.hpp"
#include "distlab/geometry/error.hpp"

namespace distlab::bench {

struct Stats {
  double mean = 0, stddev = 0, median = 0, p99 = 0, max = 0;
};

inline Stats stats(std::vector<double> v) {
  Stats s;
  if (v.empty()) return s;
  for (double x : v) s.mean += x;
  s.mean /= static_cast<double>(v.size());
  for (double x : v) s.stddev += (x - s.mean) * (x - s.mean);
  s.stddev = std::sqrt(s.stddev / static_cast<double>(v.size()));
  std::sort(v.begin(), v.end());
  s.median = v[v.size() / 2];
  s.p99 = v[std::min(v.size() - 1, v.size() * 99 / 100)];
  s.max = v.back();
  return s;
}

inline nlohmann::json to_json(const Stats& s) {
  return {{"mean", s.mean}, {"stddev", s.stddev}, {"median", s.median}, {"p99", s.p99}, {"max", s.max}};
}

inline Vec3 random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  return Vec3(n(rng), n(rng), n(rng)).normalized();
}

inline Quat random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  return Quat(n(rng), n(rng), n(rng), n(rng)).normalized();
}

// A random regular polytope with 10 half-spaces: unit normals surrounding the origin, offsets
// in [0.05, 0.15] m (robot-link sized).
inline Polytope random_polytope(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.05, 0.15);
  for (;;) {
    MatX3 A(10, 3);
    VecX b(10);
    for (int i = 0; i < 10; ++i) {
      A.row(i) = random_unit(rng).transpose();
      b[i] = u(rng);
    }
    try {
      return make_polytope(A, b, "bench");
    } catch (const InvalidInput&) {
    }
  }
}

// The paper's Section IV-A parameters: k = 2, h = 0.1, eps = 0.01, sigma = 0.989, W_i = 1/6 on
// the 10-half-space polytopes; the solver starts from the uncertified double GJK.
inline GapParams paper_params() {
  GapParams p;
  p.h = 0.1, p.k = 2, p.eps = 0.01, p.sigma = 0.989, p.gradient = false;
  p.euclidean = false;
  return p;
}

inline P2SOptions paper_polytope_options() {
  P2SOptions sixth;
  sixth.weights = VecX::Constant(10, 1.0 / 6);
  return sixth;
}

// Wall time of f in microseconds: the fastest of `repeat` back-to-back calls.
template <class F>
double time_us(int repeat, F&& f) {
  using Clock = std::chrono::steady_clock;
  double best = INFINITY;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = Clock::now();
    f();
    best = std::min(best, std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  return best;
}

}  // namespace distlab::bench
