// σ terms (eq. 24 and brushes) and their validation.
#include "distlab/kelvin/sigma.hpp"

#include <cmath>
#include <string>

#include "distlab/geometry/error.hpp"

namespace distlab::kelvin {

double evaluate(const AxisSigma& t, const Vec3& x) {
  return std::tanh((std::abs(t.axis.normalized().dot(x - t.origin)) - t.d0) / t.width) * t.sigma_nom;
}

double evaluate(const BrushSigma& t, const Vec3& x) {
  const double d = (x - t.centre).norm();
  if (d <= t.radius) return t.value;
  if (t.falloff <= 0 || d >= t.radius + t.falloff) return 0;
  const double s = 1 - (d - t.radius) / t.falloff;
  return t.value * s * s * (3 - 2 * s);
}

namespace {

void finite(double v, const std::string& field) {
  if (!std::isfinite(v)) throw InvalidInput(field, field + " must be a finite number");
}

}  // namespace

void validate(const SigmaSpec& s, Eigen::Index n_vertices) {
  finite(s.constant, "sigma.constant");
  if (s.per_vertex) {
    if (s.per_vertex->size() != n_vertices)
      throw InvalidInput("sigma.per_vertex", "sigma.per_vertex has " + std::to_string(s.per_vertex->size()) +
                                                 " values but the mesh has " + std::to_string(n_vertices) +
                                                 " vertices (after welding)");
    for (Eigen::Index i = 0; i < n_vertices; ++i)
      finite((*s.per_vertex)[i], "sigma.per_vertex[" + std::to_string(i) + "]");
  }
  for (size_t i = 0; i < s.axis.size(); ++i) {
    const std::string f = "sigma.axis[" + std::to_string(i) + "]";
    const auto& a = s.axis[i];
    if (!a.axis.allFinite() || a.axis.norm() < 1e-12) throw InvalidInput(f + ".axis", f + ".axis must be a non-zero vector");
    if (!a.origin.allFinite()) throw InvalidInput(f + ".origin", f + ".origin must be finite");
    finite(a.d0, f + ".d0");
    if (a.d0 < 0) throw InvalidInput(f + ".d0", f + ".d0 must be ≥ 0");
    finite(a.sigma_nom, f + ".sigma_nom");
    finite(a.width, f + ".width");
    if (a.width <= 0) throw InvalidInput(f + ".width", f + ".width must be positive");
  }
  for (size_t i = 0; i < s.brushes.size(); ++i) {
    const std::string f = "sigma.brushes[" + std::to_string(i) + "]";
    const auto& b = s.brushes[i];
    if (!b.centre.allFinite()) throw InvalidInput(f + ".centre", f + ".centre must be finite");
    finite(b.radius, f + ".radius");
    finite(b.value, f + ".value");
    finite(b.falloff, f + ".falloff");
    if (b.radius < 0) throw InvalidInput(f + ".radius", f + ".radius must be ≥ 0");
    if (b.falloff < 0) throw InvalidInput(f + ".falloff", f + ".falloff must be ≥ 0");
  }
}

}  // namespace distlab::kelvin
