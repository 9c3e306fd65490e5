#pragma once
// The semantic state σ on the object's surface (Section III): σ > 0 where contact is allowed.
// A SigmaSpec is a sum of terms, evaluated at surface points x (object coordinates, metres).
#include <optional>
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
};

// value within radius of centre, falling smoothly (smoothstep) to 0 over falloff beyond it.
struct BrushSigma {
  Vec3 centre = Vec3::Zero();
  double radius = 0;
  double value = 0;
  double falloff = 0;
};

struct SigmaSpec {
  double constant = 0;
  std::optional<VecX> per_vertex;  // one value per input-mesh vertex, linear over faces
  std::vector<AxisSigma> axis;
  std::vector<BrushSigma> brushes;
};

double evaluate(const AxisSigma& term, const Vec3& x);
double evaluate(const BrushSigma& term, const Vec3& x);

// Throws InvalidInput naming the offending field (prefix "sigma") on bad values; n_vertices is
// the input mesh's vertex count.
void validate(const SigmaSpec& sigma, Eigen::Index n_vertices);

}  // namespace distlab::kelvin
