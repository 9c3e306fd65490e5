#pragma once
// Checks Property 2 of Definition 1 for one strict P2S function E_S (eq. 6, Theorem 2).
//
// The region. Property 2 must hold on all of R³: ∂²E_S = 0 on S, and 0 < ∂²E_S < I on the
// unbounded complement R³ \ S (Lemma 1 needs it at every point the alternating map can visit).
// On S it holds by construction (e_S = 0 makes B = σe_S, E_S and q in eq. 18 vanish), and
// ∂²E_S > 0 outside is Lemma 5. The upper bound is what ε, σ, the weights and the ρ ball can
// break, in two places:
// - near the sphere ρ = 0, where A = ερ vanishes and eq. 18's rank-one term becomes
//   ε²‖p − c‖²/(σ e_S) = ε²R²/(σ e_S): it spikes wherever the shape comes close to the sphere,
//   in a shell whose thickness is about σ e_S/(εR) (a millimetre or less), which random
//   sampling does not hit;
// - far away, where A and B both grow quadratically and ∂²E_S tends to a limit per direction
//   (σ W on round shapes: 0.990 with the defaults).
//
// The check is a targeted maximisation of λ_max(∂²E_S): candidate points on the sphere ρ = 0
// above every vertex, edge (three points each) and face of a polytope or box, above the rims
// and caps of a cylinder and above the support points of 256 directions for every shape; far
// field points along the same directions; and `samples` random points near and around the
// shape (these also check ∂²E_S = 0 inside and > 0 outside). The best candidates of each kind
// are climbed by compass search in coordinates that follow the spheres around the ρ centre, so
// the thin shell at ρ = 0 is followed rather than stepped out of. The shape is refused when the
// largest eigenvalue found reaches 1; the report names the point. This is a search, not a
// certified bound (no interval bound is computed).
//
// Verdicts are cached per shape and parameters (the exact defining numbers, not a hash of
// them), least recently used first out, in at most kValidationCacheBytes; thread-safe.
#include <cstddef>
#include <cstdint>
#include <string>

#include "distlab/gap/point_to_set.hpp"

namespace distlab {

// Memory bound of the verdict cache (keys are the shapes' defining numbers: a 1000-row
// polytope's key is about 40 kB).
inline constexpr std::size_t kValidationCacheBytes = std::size_t{32} << 20;

struct ValidationReport {
  bool ok = false;
  double max_eigenvalue = 0;            // largest Hessian eigenvalue found outside the set
  Vec3 worst_point = Vec3::Zero();      // shape frame
  double min_eigenvalue = 0;            // smallest eigenvalue found outside the set (should be > 0)
  double min_eigenvalue_tolerance = 0;  // the eigen solver's rounding at that point
  double max_inside_norm = 0;           // largest |∂²E| found inside the set (should be 0)
  int samples = 0;                      // evaluations of ∂²E_S
  int ascents = 0;                      // local maximisations run
  bool cached = false;                  // this verdict came from the cache
  std::string message;
};

// The P2S function is evaluated in its shape frame (pose ignored). Deterministic for a seed;
// `samples` random points besides the targeted ones.
ValidationReport validate_p2s(const PointToSet& original, int samples = 2000, std::uint64_t seed = 1);

// The verdict cache's contents and counters (CacheStats, point_to_set.hpp); clear_validation_cache
// empties it, and set_validation_cache_capacity replaces kValidationCacheBytes (tests, benchmarks).
CacheStats validation_cache_stats();
void clear_validation_cache();
void set_validation_cache_capacity(std::size_t bytes);

}  // namespace distlab
