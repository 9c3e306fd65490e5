#pragma once
// Checks Property 2 of Definition 1 (0 < ∂²E_S < I outside S, ∂²E_S = 0 inside) for one strict
// P2S function by sampling around the shape and refining the worst samples. The paper offers no
// closed-form rule for ε and σ (Section III-C); this is its "test random points" advice, made
// systematic and reported.
#include <cstdint>
#include <string>

#include "distlab/gap/point_to_set.hpp"

namespace distlab {

struct ValidationReport {
  bool ok = false;
  double max_eigenvalue = 0;   // largest Hessian eigenvalue found outside the set
  Vec3 worst_point = Vec3::Zero();  // shape frame
  double min_eigenvalue = 0;   // smallest eigenvalue found outside the set (should be > 0)
  double min_eigenvalue_tolerance = 0;  // the eigen solver's rounding at that point
  double max_inside_norm = 0;  // largest |∂²E| found inside the set (should be 0)
  int samples = 0;
  std::string message;
};

// The P2S function is evaluated in its shape frame (pose ignored). Deterministic for a seed.
ValidationReport validate_p2s(const PointToSet& p2s, int samples = 4000, std::uint64_t seed = 1);

}  // namespace distlab
