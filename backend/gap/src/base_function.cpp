// Φ of eq. (4). The paper prints the sign of term i as (−1)^(k−1−i); expanding
// (1 − x^(−1/h))^(k−1) gives (−1)^i, which is what is used here (the printed sign makes Φ < 0
// for k = 2). With x = s + 1, L = ln x and a_i = i/h, integrating Φ'' = Σ c_i x^(−a_i) twice:
//   Φ'(s) = Σ c_i E(1 − a_i),   Φ(s) = Σ c_i [x E(1 − a_i) − E(2 − a_i)],
//   E(β) = ∫_0^L e^(βt) dt = (x^β − 1)/β,  E(0) = L,
// which covers the singular cases a_i = 1 and a_i = 2 without a separate limit form.
// Near s = 0 the terms cancel (Φ ~ s^(k+1)); there a Taylor series in L is used instead.
#include "distlab/gap/base_function.hpp"

#include <cmath>
#include <string>

#include "distlab/geometry/error.hpp"

namespace distlab {
namespace {

constexpr int kSeriesTerms = 44;

using Poly = std::vector<long double>;

Poly multiply(const Poly& p, const Poly& q) {
  Poly r(kSeriesTerms, 0.0L);
  for (int i = 0; i < kSeriesTerms; ++i)
    for (int j = 0; i + j < kSeriesTerms; ++j) r[i + j] += p[i] * q[j];
  return r;
}

// ∫_0^L p(t) e^t dt as a series in L.
Poly integrate_times_exp(const Poly& p) {
  Poly exp_series(kSeriesTerms);
  long double f = 1.0L;
  for (int n = 0; n < kSeriesTerms; ++n) {
    exp_series[n] = 1.0L / f;
    f *= (n + 1);
  }
  const Poly q = multiply(p, exp_series);
  Poly r(kSeriesTerms, 0.0L);
  for (int n = 0; n + 1 < kSeriesTerms; ++n) r[n + 1] = q[n] / (n + 1);
  return r;
}

double horner(const std::vector<double>& c, double L) {
  double r = 0;
  for (auto it = c.rbegin(); it != c.rend(); ++it) r = r * L + *it;
  return r;
}

// E(β) = (x^β − 1)/β with x^β given; expm1 where x^β is close to 1.
inline double E(double beta, double x_beta, double L) {
  const double z = beta * L;
  if (std::abs(z) < 0.5) return z == 0.0 ? L : std::expm1(z) / beta;
  return (x_beta - 1.0) / beta;
}

}  // namespace

BaseFunction::BaseFunction(double h, int k) : h_(h), k_(k) {
  if (!std::isfinite(h) || h <= 0)
    throw InvalidInput("params.h", "h must be a finite number > 0, got " + std::to_string(h));
  if (k < 2 || k > kMaxK)
    throw InvalidInput("params.k", "k must be an integer in [2, " + std::to_string(kMaxK) +
                                       "], got " + std::to_string(k));
  binom_.assign(k, 0.0);
  double c = 1.0;
  for (int i = 0; i < k; ++i) {
    binom_[i] = (i % 2 ? -c : c);
    c = c * (k - 1 - i) / (i + 1);
  }
  // Φ''(t) = (1 − e^(−t/h))^(k−1) as a series in t = L; its coefficients grow like
  // ((k−1)/h)^n/n!, so the series is used while (k−1) L / h <= 4 (and L <= 4): the truncation
  // error is then below 4^44/44! and the closed form's cancellation above it stays near 1e-14.
  Poly g(kSeriesTerms, 0.0L);  // 1 − e^(−t/h)
  long double term = 1.0L;
  for (int n = 1; n < kSeriesTerms; ++n) {
    term *= (-1.0L / h) / n;
    g[n] = -term;
  }
  Poly p(kSeriesTerms, 0.0L);
  p[0] = 1.0L;
  for (int i = 0; i < k - 1; ++i) p = multiply(p, g);
  const Poly p1 = integrate_times_exp(p);
  const Poly p0 = integrate_times_exp(p1);
  c2_.assign(p.begin(), p.end());
  c1_.assign(p1.begin(), p1.end());
  c0_.assign(p0.begin(), p0.end());
  series_limit_ = std::min(4.0, 4.0 * h / (k - 1));
}

BaseFunction::Jet BaseFunction::series(double L) const {
  return {horner(c0_, L), horner(c1_, L), horner(c2_, L)};
}

BaseFunction::Jet BaseFunction::closed_form(double s, double L) const {
  const double x = s + 1.0;
  const double t = std::exp(-L / h_);  // x^(−1/h)
  Jet j;
  double xa = 1.0;  // x^(−i/h)
  for (int i = 0; i < k_; ++i) {
    const double a = i / h_;
    const double e1 = E(1.0 - a, x * xa, L);
    const double e2 = E(2.0 - a, x * x * xa, L);
    j.value += binom_[i] * (x * e1 - e2);
    j.d1 += binom_[i] * e1;
    xa *= t;
  }
  // Here L/h > 4/(k−1) >= 1/3, so 1 − t has no cancellation.
  j.d2 = std::pow(1.0 - t, k_ - 1);
  return j;
}

BaseFunction::Jet BaseFunction::jet(double s) const {
  if (!(s > 0)) return {};
  const double L = std::log1p(s);
  return L <= series_limit_ ? series(L) : closed_form(s, L);
}

}  // namespace distlab
