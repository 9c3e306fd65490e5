#pragma once
// The analytic reference of the Kelvin tests: a sphere of radius R centred at s with constant σ
// has u = e^(−σ) R/|x − s|, so h = σ + ln(|x − s|/R) and ∇h = (x − s)/|x − s|².
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "distlab/kelvin/field.hpp"
#include "distlab/mesh/primitives.hpp"

namespace distlab::kelvin::testing {

struct Sphere {
  double radius = 0.5;
  Vec3 centre = Vec3::Zero();
  double sigma = 0.3;
  double h(const Vec3& x) const { return sigma + std::log((x - centre).norm() / radius); }
  Vec3 gradient(const Vec3& x) const { return (x - centre) / (x - centre).squaredNorm(); }
};

// Inversion centre deliberately off the sphere's centre: otherwise V is constant and exact on
// any mesh, and the tests would prove nothing.
inline PrepareOptions sphere_options(double lx) {
  PrepareOptions o;
  o.lx = lx;
  o.centre = Vec3(0.12, -0.07, 0.05);
  return o;
}

inline SigmaSpec constant_sigma(double value) {
  SigmaSpec spec;
  spec.constant = value;
  return spec;
}

// Level-6 icosphere: its faces lie within 2e-5 R of the sphere, below the errors measured.
inline mesh::SurfaceMesh sphere_mesh(const Sphere& s) { return mesh::icosphere(s.radius, 6, s.centre); }

// Deterministic points in the shell R·[lo, hi] around the sphere.
inline std::vector<Vec3> shell_points(const Sphere& s, double lo, double hi, int n, unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> r(lo, hi);
  std::vector<Vec3> out;
  for (int i = 0; i < n; ++i) out.emplace_back(s.centre + s.radius * r(rng) * Vec3(g(rng), g(rng), g(rng)).normalized());
  return out;
}

// Largest |a − b| over the vertices that carry a value, relative to the largest |b|; NaN
// (unused points) must be at the same places.
inline double relative_difference(const VecX& a, const VecX& b) {
  double diff = 0, scale = 0;
  for (Eigen::Index v = 0; v < b.size(); ++v) {
    if (std::isnan(b[v]) || std::isnan(a[v])) {
      if (std::isnan(b[v]) != std::isnan(a[v])) return INFINITY;
      continue;
    }
    diff = std::max(diff, std::abs(a[v] - b[v]));
    scale = std::max(scale, std::abs(b[v]));
  }
  return diff / scale;
}

// A constant plus an axis term: the σ the stroke tests paint on.
inline SigmaSpec tilted_sigma(const Sphere& s, double constant) {
  SigmaSpec spec = constant_sigma(constant);
  spec.axis.push_back({Vec3(0.3, 1, 0.2), s.centre, 0.1, 0.8, 0.2});
  return spec;
}

}  // namespace distlab::kelvin::testing
