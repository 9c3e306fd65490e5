#pragma once
// The semantic state σ on the object's surface (Section III): σ > 0 where contact is allowed.
// A SigmaSpec is a sum of terms, evaluated at surface points x (object coordinates, metres).
#include <optional>
#include <string>
#include <vector>

#include "distlab/geometry/types.hpp"

namespace distlab::kelvin {

// Eq. 24: σ(x) = tanh((|e_lᵀ(x − origin)| − d0) / width) σ_nom. width = 1 is the paper's form.
struct AxisSigma {
  Vec3 axis = Vec3::UnitX();
  Vec3 origin = Vec3::Zero();
  double d0 = 0;
  double sigma_nom = 1;
  double width = 1;
  bool operator==(const AxisSigma&) const = default;
};

// Weight w(x) = 1 within radius of centre, falling smoothly (smoothstep) to 0 over falloff beyond
// it. An added brush is the term value · w(x). A brush "towards" value moves the σ of the terms
// before it instead, σ ← σ + w(x) (value − σ): a convex combination of σ and value at every point,
// so overlapping stamps neither pile up nor pass value (an added stamp of value − σ(centre) does,
// wherever σ under it is not σ(centre)).
struct BrushSigma {
  Vec3 centre = Vec3::Zero();
  double radius = 0;
  double value = 0;
  double falloff = 0;
  bool towards = false;
  bool operator==(const BrushSigma&) const = default;
};

// The range of σ, of every term and of their sum anywhere on the surface: |σ| ≤ kMaxAbsSigma.
// The boundary values are V_∂ = e^(−σ)/|y| (eq. 17) and h = −ln(|y| V) (eq. 16), so σ = 1e39
// made V ≡ 0 (h = +inf, float32 frames got inf) and σ = 1e300 made h null. e^(±300) ≈ 10^(±130)
// leaves more than 10^170 of double's normal range (10^(±308)) on each side for |y| and the
// stiffness entries of any mesh the coordinate limits allow, so V_∂, the right-hand side
// −A_Ω∂ V_∂ and V neither overflow nor become subnormal, h is finite wherever V > 0, and σ and h
// fit float32 frames. No use is lost: e^(−300) is 10^(−130) of e^0.
inline constexpr double kMaxAbsSigma = 300;

struct SigmaSpec {
  double constant = 0;
  // One value per vertex, linear over faces. At the API: per user (file) vertex; inside Field:
  // per welded vertex (weld_sigma maps one to the other).
  std::optional<VecX> per_vertex;
  std::vector<AxisSigma> axis;
  std::vector<BrushSigma> brushes;  // applied in order, after the other terms
};

double evaluate(const AxisSigma& term, const Vec3& x);
double weight(const BrushSigma& term, const Vec3& x);
// σ at x after the brush, given σ at x from the terms before it (towards or added).
double apply(const BrushSigma& term, double sigma, const Vec3& x);

// σ at surface point x: `base` (the constant and the per-vertex values interpolated at x, the
// part that is not a function of x alone) plus the axis terms, then the brushes in order.
double evaluate(const SigmaSpec& sigma, const Vec3& x, double base);

// Throws InvalidInput naming the offending field (prefix "sigma") on bad values, including any
// term outside [−kMaxAbsSigma, kMaxAbsSigma]; n_vertices is the length per_vertex must have.
void validate(const SigmaSpec& sigma, Eigen::Index n_vertices);

// The one check of the summed σ (all terms) at surface point x: InvalidInput("sigma") naming x
// and the sum when |σ| > kMaxAbsSigma. where: how x is known to the user ("vertex 12", …).
void require_sigma_in_range(double total, const Vec3& x, const std::string& where);

// σ at every vertex of a surface, all terms summed: the constant, per_vertex[v] (if given, one
// value per row of `vertices`), the axis terms, then the brushes.
std::vector<double> evaluate_at_vertices(const SigmaSpec& sigma, const MatX3& vertices);

// σ given per user vertex (to_welded.size() values, see mesh/weld.hpp) as σ per welded vertex.
// Validates (field names index user vertices). User vertices at one position (same welded vertex)
// must carry the same value to 1e-9 · max(1, |σ|): they are one point of the surface, and a
// silent average would hide a σ array that belongs to another mesh or order. Unused vertices
// (to_welded −1) are validated and otherwise ignored.
SigmaSpec weld_sigma(const SigmaSpec& user, const std::vector<int>& to_welded, Eigen::Index n_welded);

// The σ a field solves for σ as the user gave it on `user_vertices` (the mesh before welding):
// weld_sigma, after the summed σ is checked at every user vertex (require_sigma_in_range).
SigmaSpec field_sigma(const SigmaSpec& user, const MatX3& user_vertices, const std::vector<int>& to_welded,
                      Eigen::Index n_welded);

}  // namespace distlab::kelvin
