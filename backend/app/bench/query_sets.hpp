#pragma once
// The Kelvin query benchmark's point sets, shared by distlab-bench-kelvin and
// distlab-kelvin-query-profile so both time the same points: a smooth path around the unit cube
// (hinted queries) and 1000 uniform random points in [−3, 3]³ outside it (hint-less queries and
// the AABB baseline).
#include <cmath>
#include <random>
#include <vector>

#include "distlab/geometry/types.hpp"

namespace distlab::bench {

struct QuerySets {
  std::vector<Vec3> path, random;
};

inline QuerySets kelvin_query_sets() {
  QuerySets q;
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-3, 3);
  for (int i = 0; i < 1000; ++i) {
    const double t = 2 * M_PI * i / 1000;
    q.path.emplace_back(1.5 * std::cos(t), 1.5 * std::sin(t), 0.4 * std::sin(3 * t));
  }
  while (q.random.size() < 1000) {
    const Vec3 x(u(rng), u(rng), u(rng));
    if (x.cwiseAbs().maxCoeff() > 0.5) q.random.push_back(x);
  }
  return q;
}

}  // namespace distlab::bench
