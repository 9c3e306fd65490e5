#pragma once
// Point-to-set functions of one shape: the weak e_S (eq. 5 and its round-shape analogues) and the
// strict E_S = ερ + sqrt(ε²ρ² + σ²e_S²) of eq. (6) (Theorem 2) with ρ = ½(‖p − c‖² − R²).
#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "distlab/gap/base_function.hpp"
#include "distlab/geometry/shape.hpp"

namespace distlab {

struct StrictParams {
  double eps = 0.01;
  double sigma = 0.9899494936611665;  // sqrt(1 − 2ε), the published package's choice
};

// Per-shape options; everything has a documented default.
// The default ρ ball is the bounding ball scaled by kDefaultRhoScale. The published package
// uses R² = 1.2 × (half diagonal)², but with ε = 0.01, σ = sqrt(1 − 2ε) that breaks Property 2
// near the corners of most shapes (∂²E reaches 1.5–3: ρ is small there, and ∂²E grows like
// σ²∇e∇eᵀ/(ε|ρ|)); from a scale of 1.5 on, the validator finds every tested shape below 0.7.
inline constexpr double kDefaultRhoScale = 1.5;

struct P2SOptions {
  // Polytopes/boxes: W_i. Default 1/(m + weight_margin) (Section III-B); for a hull of points
  // (Polytope::is_hull) or a polytope of more than kAreaWeightedRows rows
  // w_i / (K (1 + weight_margin)) with w_i = A_i + Ā (A_i the facet's area, Ā their mean) and K
  // max_violated_eigenvalue_bound of w, so that Σ_violated W_i a_i a_iᵀ < I still.
  std::optional<VecX> weights;
  double weight_margin = 0.01;  // the small positive number in W_i = 1/(m + ε), Section III-B
  std::optional<Ball> rho;      // ball of ρ in the shape frame; default: bounding ball scaled
  // Round shapes (sphere, cylinder, capsule): the weight of their terms, in (0, 1]; default
  // 1/(1 + weight_margin). The published package uses 1 (Φ'' < 1 keeps Property 2 of e_S).
  std::optional<double> round_weight;
};

template <class T>
using Vec3T = Eigen::Matrix<T, 3, 1>;
template <class T>
using Mat3T = Eigen::Matrix<T, 3, 3>;
// T's precision against double's: relative stop rules and rounding allowances set for double
// are scaled by it in wider scalars (the long-double reference); exactly 1 for double.
template <class T>
constexpr T kPrecisionScale = std::numeric_limits<T>::epsilon() / std::numeric_limits<double>::epsilon();

// A value with optional first and second derivatives (world or local frame as stated).
template <class T>
struct P2SValueT {
  T value = 0;
  Vec3T<T> gradient = Vec3T<T>::Zero();
  Mat3T<T> hessian = Mat3T<T>::Zero();
};
using P2SValue = P2SValueT<double>;

// A rigid pose in scalar T (PointToSet::strict_at).
template <class T>
struct PoseT {
  Vec3T<T> position = Vec3T<T>::Zero();
  Eigen::Quaternion<T> rotation = Eigen::Quaternion<T>::Identity();
  static PoseT from(const Pose& p) { return {p.position.cast<T>(), p.rotation.cast<T>()}; }
};

// Contents and counters of an exact-key cache (the hull weights below, the validator's verdicts).
struct CacheStats {
  std::size_t entries = 0, bytes = 0, capacity = 0, hits = 0, misses = 0;
};

// A hull's weights (max_violated_eigenvalue_bound: seconds for thousands of facets) are computed
// once per hull and weight_margin and kept, keyed by the hull's exact numbers, in at most this many
// bytes (a 2,886-facet hull's entry is ~0.3 MB: its rows, faces and vertices twice), so a robot's
// model rebuilt for another obstacle set reuses them. Thread-safe; least recently used out first.
inline constexpr std::size_t kHullWeightCacheBytes = std::size_t{64} << 20;
CacheStats hull_weight_cache_stats();
void clear_hull_weight_cache();

class PointToSet {
 public:
  // Throws InvalidInput naming `field` (e.g. "a.weights[2]", "a.rho.radius") on bad options:
  // weights not positive/finite or of the wrong count, or a ρ ball that does not strictly cover
  // the shape.
  PointToSet(const Shape& shape, const BaseFunction& phi, const StrictParams& strict,
             const P2SOptions& options, const std::string& field);

  // Moves the shape; evaluations below are in world coordinates.
  void set_pose(const Pose& pose);
  const Pose& pose() const { return pose_; }
  const Mat3& rotation() const { return R_; }  // pose().R(), kept from set_pose

  // e_S and E_S at a world point. `order` 0: value only, 1: + gradient, 2: + Hessian.
  P2SValue weak(const Vec3& p, int order) const;
  P2SValue strict(const Vec3& p, int order) const;
  // strict() of this shape at p and of `other` at q (the solver's E_B at a and E_A at b), the
  // same values bit for bit. Between polytopes (or boxes) with the same Φ the two evaluations
  // are done together: their violated rows are listed first, then every Φ term of both is
  // evaluated in one loop, then each sum is taken in row order. One evaluation alone leaves the
  // core waiting on each term's chain of dependent operations; here the other's fill the gaps.
  void strict_pair(const Vec3& p, const PointToSet& other, const Vec3& q, int order, P2SValue& out,
                   P2SValue& other_out) const;
  // E_S in scalar T (long double) with the shape at `pose`, from the shape's own data (the
  // world-frame rows set_pose caches are doubles): the formulas of strict(), without double's
  // rounding, which near contact is ~1e-9 of D (s = u·p − b ~ 1e-7 against |p| ~ 0.3). A
  // reference for checks (gap_gradient_extended); T = long double is instantiated.
  template <class T>
  P2SValueT<T> strict_at(const Vec3T<T>& p, const PoseT<T>& pose, int order) const;
  // Hints the CPU to load the evaluation data (half-space rows) into cache, e.g. while the
  // Euclidean start is computed; no effect on results.
  void prefetch() const {
    prefetch_bytes(soa_.data(), soa_.size() * sizeof(double));
  }
  // The same for a polytope's vertices, which the Euclidean start's support calls read first:
  // on a cold call their misses otherwise stall each of GJK's first support points.
  void prefetch_vertices() const {
    if (const auto* poly = std::get_if<Polytope>(&shape_))
      prefetch_bytes(poly->vertices.data(), poly->vertices.size() * sizeof(Vec3));
  }
  // True if p is in the set (e_S = 0): exact zero test, consistent with E_S = 0.
  bool contains(const Vec3& p) const { return weak(p, 0).value == 0.0; }

  const VecX& weights() const { return weights_; }  // empty for round shapes
  const Ball& rho_ball() const { return rho_; }     // shape frame
  const Shape& shape() const { return shape_; }
  const StrictParams& strict_params() const { return strict_; }
  const BaseFunction& phi() const { return phi_; }
  double round_weight() const { return round_weight_; }  // round shapes' weight

 private:
  static void prefetch_bytes(const void* data, size_t bytes) {
    const char* p = static_cast<const char*>(data);
    for (size_t i = 0; i < bytes; i += 64) __builtin_prefetch(p + i);
  }
  template <class T>
  P2SValueT<T> weak_local(const Vec3T<T>& p, int order) const;
  template <int Order>
  P2SValue halfspaces_world(const Vec3& p) const;
  P2SValue round_world(const Vec3& p, int order) const;  // spheres and cylinders
  // strict_pair's pieces: the rows violated at p (s > 0) in row order, their s and indices
  // (returns the count; at most kPairRows padded rows), and eq. (5)'s sum over them from their Φ
  // terms, as halfspaces_world adds them.
  static constexpr size_t kPairRows = 64;
  struct Term {
    double value, d1, d2;
  };
  unsigned violated_rows(const Vec3& p, double* s, unsigned* index) const;
  template <int Order>
  P2SValue sum_rows(const unsigned* index, const Term* terms, unsigned count) const;
  template <class T>
  P2SValueT<T> capsule_local(const Vec3T<T>& p, int order) const;

  Shape shape_;
  BaseFunction phi_;
  StrictParams strict_;
  Pose pose_;
  Mat3 R_ = Mat3::Identity();
  MatX3 A_local_, A_world_;  // half-spaces (polytopes and boxes)
  VecX b_local_, b_world_;
  VecX weights_;
  // The world-frame rows for the evaluation (set_pose): five arrays, u_x, u_y, u_z (the unit
  // normal), b (the row is violated where u·p > b) and W_i, each padded to an even count. 40
  // bytes a row: a cold call fetches few cache lines (the weighted outer products W u uᵀ are
  // formed where a row is violated instead of being stored).
  static constexpr size_t kRowArrays = 5;
  std::vector<double> soa_;
  double round_weight_ = 1.0;
  Ball rho_{Vec3::Zero(), 1.0};
  Vec3 rho_center_world_ = Vec3::Zero();
};

}  // namespace distlab
