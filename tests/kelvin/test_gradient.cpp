// ∇h as queries return it against the derivative of the h they return (central differences).
// The returned gradient is the paper's (Section IV-B.2 and Algorithm 1): vertex gradients of V,
// volume-weighted over each vertex's star [36], interpolated in the cell, then the chain rule
// (eq. 18). It is continuous across cells; the derivative of the returned h, −ln(|y| V_P1), jumps
// across every face, as V_P1 is piecewise linear. So the two differ, by O(l_x): this test
// measures by how much, that it falls as l_x shrinks, and that the returned gradient is the more
// accurate of the two against the exact one (the reason for the smoothing).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "sphere_fixture.hpp"

using namespace distlab;
using namespace distlab::kelvin;
using namespace distlab::kelvin::testing;

namespace {

struct GradientGaps {
  double returned_vs_fd = 0;  // |∇h returned − central difference of h| / |∇h exact|, RMS
  double fd_vs_exact = 0;
  double returned_vs_exact = 0;
};

GradientGaps measure(double lx) {
  const Sphere s;
  Field field = Field::prepare(sphere_mesh(s), sphere_options(lx));
  field.set_sigma(constant_sigma(s.sigma));
  GradientGaps g;
  const auto points = shell_points(s, 1.1, 4.0, 1000, 11);
  for (const Vec3& x : points) {
    const Sample q = field.query(x);
    EXPECT_EQ(q.status, Status::ok);
    // A step far below the cell size: the stencil stays in the cell but for a few points.
    const double step = 1e-6 * (x - field.centre()).norm();
    Vec3 fd;
    for (int k = 0; k < 3; ++k) {
      Vec3 e = Vec3::Zero();
      e[k] = step;
      fd[k] = (field.query(Vec3(x + e)).h - field.query(Vec3(x - e)).h) / (2 * step);
    }
    const double scale = s.gradient(x).squaredNorm();
    g.returned_vs_fd += (q.gradient - fd).squaredNorm() / scale;
    g.fd_vs_exact += (fd - s.gradient(x)).squaredNorm() / scale;
    g.returned_vs_exact += (q.gradient - s.gradient(x)).squaredNorm() / scale;
  }
  const double n = static_cast<double>(points.size());
  g.returned_vs_fd = std::sqrt(g.returned_vs_fd / n);
  g.fd_vs_exact = std::sqrt(g.fd_vs_exact / n);
  g.returned_vs_exact = std::sqrt(g.returned_vs_exact / n);
  std::printf("lx %.3f  verts %ld  relative RMS: returned - FD(h) %.3e  FD(h) - exact %.3e  returned - exact %.3e\n", lx,
              field.stats().n_verts, g.returned_vs_fd, g.fd_vs_exact, g.returned_vs_exact);
  return g;
}

}  // namespace

TEST(KelvinGradient, ReturnedGradientIsTheDerivativeOfHToOrderLx) {
  const double lxs[] = {0.2, 0.1, 0.07};
  GradientGaps prev;
  for (int i = 0; i < 3; ++i) {
    const GradientGaps g = measure(lxs[i]);
    // The smoothing brings the gradient closer to the exact one than h's own derivative is.
    EXPECT_LT(g.returned_vs_exact, g.fd_vs_exact);
    if (i > 0) {
      const double order = std::log(prev.returned_vs_fd / g.returned_vs_fd) / std::log(lxs[i - 1] / lxs[i]);
      std::printf("observed order of returned - FD(h): %.2f\n", order);
      EXPECT_GT(order, 0.8);  // P1: the derivative of h converges at order 1
    }
    prev = g;
  }
}
