// σ terms (eq. 24 and brushes) and their validation.
#include "distlab/kelvin/sigma.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "distlab/geometry/error.hpp"

namespace distlab::kelvin {

double evaluate(const AxisSigma& t, const Vec3& x) {
  return std::tanh((std::abs(t.axis.normalized().dot(x - t.origin)) - t.d0) / t.width) * t.sigma_nom;
}

double weight(const BrushSigma& t, const Vec3& x) {
  const double d = (x - t.centre).norm();
  if (d <= t.radius) return 1;
  if (t.falloff <= 0 || d >= t.radius + t.falloff) return 0;
  const double s = 1 - (d - t.radius) / t.falloff;
  return s * s * (3 - 2 * s);
}

double apply(const BrushSigma& t, double sigma, const Vec3& x) {
  const double w = weight(t, x);
  // (1 − w) σ + w value rather than σ + w (value − σ): exactly value where w = 1.
  return t.towards ? (1 - w) * sigma + w * t.value : sigma + w * t.value;
}

double evaluate(const SigmaSpec& sigma, const Vec3& x, double base) {
  double s = base;
  for (const auto& a : sigma.axis) s += evaluate(a, x);
  for (const auto& br : sigma.brushes) s = apply(br, s, x);
  return s;
}

std::vector<double> evaluate_at_vertices(const SigmaSpec& sigma, const MatX3& vertices) {
  std::vector<double> out(static_cast<std::size_t>(vertices.rows()), sigma.constant);
  for (Eigen::Index v = 0; v < vertices.rows(); ++v) {
    double& s = out[static_cast<std::size_t>(v)];
    if (sigma.per_vertex && v < sigma.per_vertex->size()) s += (*sigma.per_vertex)[v];
    s = evaluate(sigma, vertices.row(v).transpose(), s);
  }
  return out;
}

namespace {

void finite(double v, const std::string& field) {
  if (!std::isfinite(v)) throw InvalidInput(field, field + " must be a finite number");
}

std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// A value that is σ itself (not a position or a width): finite and within the range.
void sigma_value(double v, const std::string& field) {
  finite(v, field);
  if (std::abs(v) > kMaxAbsSigma)
    throw InvalidInput(field, field + " = " + number_text(v) + " is outside the range of σ, [−" +
                                  number_text(kMaxAbsSigma) + ", " + number_text(kMaxAbsSigma) + "]");
}

}  // namespace

void validate(const SigmaSpec& s, Eigen::Index n_vertices) {
  sigma_value(s.constant, "sigma.constant");
  if (s.per_vertex) {
    if (s.per_vertex->size() != n_vertices)
      throw InvalidInput("sigma.per_vertex", "sigma.per_vertex has " + std::to_string(s.per_vertex->size()) +
                                                 " values but the mesh has " + std::to_string(n_vertices) +
                                                 " vertices (one value per vertex of the mesh as given, in its order)");
    for (Eigen::Index i = 0; i < n_vertices; ++i)
      sigma_value((*s.per_vertex)[i], "sigma.per_vertex[" + std::to_string(i) + "]");
  }
  for (size_t i = 0; i < s.axis.size(); ++i) {
    const std::string f = "sigma.axis[" + std::to_string(i) + "]";
    const auto& a = s.axis[i];
    if (!a.axis.allFinite() || a.axis.norm() < 1e-12) throw InvalidInput(f + ".axis", f + ".axis must be a non-zero vector");
    if (!a.origin.allFinite()) throw InvalidInput(f + ".origin", f + ".origin must be finite");
    finite(a.d0, f + ".d0");
    if (a.d0 < 0) throw InvalidInput(f + ".d0", f + ".d0 must be ≥ 0");
    sigma_value(a.sigma_nom, f + ".sigma_nom");
    finite(a.width, f + ".width");
    if (a.width <= 0) throw InvalidInput(f + ".width", f + ".width must be positive");
  }
  for (size_t i = 0; i < s.brushes.size(); ++i) {
    const std::string f = "sigma.brushes[" + std::to_string(i) + "]";
    const auto& b = s.brushes[i];
    if (!b.centre.allFinite()) throw InvalidInput(f + ".centre", f + ".centre must be finite");
    finite(b.radius, f + ".radius");
    sigma_value(b.value, f + ".value");
    finite(b.falloff, f + ".falloff");
    if (b.radius < 0) throw InvalidInput(f + ".radius", f + ".radius must be ≥ 0");
    if (b.falloff < 0) throw InvalidInput(f + ".falloff", f + ".falloff must be ≥ 0");
    // A brush of radius and falloff 0 paints nothing (only its centre): a mistake, not a no-op.
    if (!(b.radius + b.falloff > 0)) throw InvalidInput(f + ".radius", f + ".radius + falloff must be > 0");
  }
}

void require_sigma_in_range(double total, const Vec3& x, const std::string& where) {
  if (std::abs(total) <= kMaxAbsSigma) return;  // NaN cannot arise: every term is finite
  throw InvalidInput("sigma", "the terms of sigma add up to " + number_text(total) + " at " + where + " (" +
                                  number_text(x.x()) + ", " + number_text(x.y()) + ", " + number_text(x.z()) +
                                  "), outside the range of σ, [−" + number_text(kMaxAbsSigma) + ", " +
                                  number_text(kMaxAbsSigma) + "]");
}

SigmaSpec weld_sigma(const SigmaSpec& user, const std::vector<int>& to_welded, Eigen::Index n_welded) {
  validate(user, static_cast<Eigen::Index>(to_welded.size()));
  SigmaSpec out = user;
  if (!user.per_vertex) return out;
  const VecX& in = *user.per_vertex;
  VecX welded = VecX::Constant(n_welded, std::numeric_limits<double>::quiet_NaN());
  std::vector<Eigen::Index> first(static_cast<std::size_t>(n_welded), -1);
  for (Eigen::Index i = 0; i < in.size(); ++i) {
    const int w = to_welded[static_cast<std::size_t>(i)];
    if (w < 0) continue;
    Eigen::Index& f = first[static_cast<std::size_t>(w)];
    if (f < 0) {
      f = i;
      welded[w] = in[i];
    } else if (std::abs(in[i] - welded[w]) > 1e-9 * std::max(1.0, std::abs(welded[w]))) {
      const std::string field = "sigma.per_vertex[" + std::to_string(i) + "]";
      throw InvalidInput(field, field + " = " + number_text(in[i]) + " differs from sigma.per_vertex[" +
                                    std::to_string(f) + "] = " + number_text(welded[w]) +
                                    ": vertices " + std::to_string(f) + " and " + std::to_string(i) +
                                    " have the same position, and one point of the surface has one σ");
    }
  }
  out.per_vertex = welded;
  return out;
}

SigmaSpec field_sigma(const SigmaSpec& user, const MatX3& user_vertices, const std::vector<int>& to_welded,
                      Eigen::Index n_welded) {
  SigmaSpec welded = weld_sigma(user, to_welded, n_welded);
  const std::vector<double> total = evaluate_at_vertices(user, user_vertices);
  for (std::size_t v = 0; v < total.size(); ++v)
    require_sigma_in_range(total[v], user_vertices.row(static_cast<Eigen::Index>(v)).transpose(), "vertex " + std::to_string(v));
  return welded;
}

}  // namespace distlab::kelvin
