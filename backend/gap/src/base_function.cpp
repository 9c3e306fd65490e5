// Φ of eq. (4). The paper prints the sign of term i as (−1)^(k−1−i); expanding
// (1 − x^(−1/h))^(k−1) gives (−1)^i, which is what is used here (the printed sign makes Φ < 0
// for k = 2). With x = s + 1, L = ln x and a_i = i/h, integrating Φ'' = Σ c_i x^(−a_i) twice:
//   Φ'(s) = Σ c_i E(1 − a_i),   Φ(s) = Σ c_i [x E(1 − a_i) − E(2 − a_i)],
//   E(β) = ∫_0^L e^(βt) dt = (x^β − 1)/β,  E(0) = L,
// which covers the singular cases a_i = 1 and a_i = 2 without a separate limit form.
// Near s = 0 the terms cancel (Φ ~ s^(k+1)); there a Taylor series in L is used instead.
//
// For integer n = 1/h >= 3 (h = 0.1, the paper's choice, among them) every exponent −i n is an
// integer and Φ^(d) (1+s)^N, N = (k−1) n, is a polynomial in s (no log term: the singular
// exponents 1 and 2 need n <= 2) that vanishes to order k+1−d at s = 0, so
//   Φ^(d)(s) = s^(k+1−d) P_d(s) / (1+s)^N,
// and P_d, built once in exact integer arithmetic, turns out to have positive coefficients
// (checked when built; otherwise this form is not used). Sums of positive terms and one
// division have no cancellation anywhere, so this replaces both the series and the closed form
// (log1p, exp, expm1) with four short polynomials (Estrin's scheme, base_function.hpp).
// k = 2, n = 10: Φ'' = s Σ_{j<10} C(10, j+1) s^j / (1+s)^10. Against 50-digit references the
// error is at most a few ulp (the closed form lost up to ~500 ulp in Φ near the series limit).
#include "distlab/gap/base_function.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "distlab/geometry/error.hpp"

namespace distlab {
namespace {

constexpr int kSeriesTerms = 60;

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

// Series limit in u = (k−1) L / h: the closed form's relative cancellation grows like
// 1/Φ''(L) ~ (k−1)^(k−1)/u^(k−1) below it, so larger k keeps the series longer.
double series_limit_u(int k) { return std::min(4.0, 0.5 + 0.75 * (k - 2)); }

// E(β) = (x^β − 1)/β with x^β given; expm1 where x^β is close to 1 (L = ln x).
template <class T>
inline T E(T beta, T x_beta, T L) {
  const T z = beta * L;
  if (std::abs(z) < T(0.5)) return z == T(0) ? L : std::expm1(z) / beta;
  return (x_beta - T(1)) / beta;
}

}  // namespace

namespace {

template <int... T>
constexpr std::array<BaseFunction::RationalForm, sizeof...(T)> rational_table(
    std::integer_sequence<int, T...>) {
  return {&BaseFunction::rational_form<T>...};
}

}  // namespace

void BaseFunction::build_rational_form() {
  const double inv = 1.0 / h_;
  if (!(inv >= 3 && inv <= kMaxDegree && inv == std::floor(inv))) return;
  const int n = static_cast<int>(inv), K = k_ - 1, N = K * n;
  if (N > kMaxDegree) return;
  // Magnitudes stay below 1e20 for N <= 20 (|D| <= 1.3e10, binomials <= 2e5).
  __extension__ typedef __int128 Int;
  Int D = 1;  // common denominator: Π_{i=1..K} (1 − i n)(2 − i n)
  for (int i = 1; i <= K; ++i) D *= Int(1 - i * n) * Int(2 - i * n);
  // Q[d][m]: coefficient of x^m in D Φ^(d)(s) x^(N−2+d), from Φ'' = Σ_i c_i x^(−i n),
  // c_i = (−1)^i C(K, i), integrated twice from s = 0 (see the E(β) form above).
  Int Q[3][kMaxDegree + 1] = {};
  Int c = 1;
  for (int i = 0; i <= K; ++i) {
    const int a = N - i * n;
    const Int f1 = D / (1 - i * n), f0 = D / (Int(1 - i * n) * (2 - i * n));
    Q[2][a] += c * D;
    Q[1][a] += c * f1;
    Q[1][N - 1] -= c * f1;
    Q[0][a] += c * f0;
    Q[0][N - 2] -= c * f0;
    Q[0][N - 1] -= c * f1;
    Q[0][N - 2] += c * f1;
    c = -c * (K - i) / (i + 1);
  }
  Int binom[kMaxDegree + 3][kMaxDegree + 3] = {};
  for (int m = 0; m <= N + 2; ++m) {
    binom[m][0] = 1;
    for (int j = 1; j <= m; ++j) binom[m][j] = binom[m - 1][j - 1] + (j < m ? binom[m - 1][j] : 0);
  }
  // Φ^(d) (1+s)^N = s^(k+1−d) P_d(s), P_d(s) = R_d(s) (1+s)^(2−d): the same degree N − K for
  // d = 0, 1, 2, one denominator for all three. Lanes 0..2 of r: P_0, P_1, P_2; lane 3:
  // (1+s)^N = Σ C(N, j) s^j; zero-padded to N + 1 coefficients.
  std::array<double, 4 * (kMaxDegree + 1)> r{};
  for (int d = 0; d < 3; ++d) {
    const int order = K + 2 - d;  // Φ^(d) ~ s^order
    for (int j = 0; j <= N + 2 - d; ++j) {
      Int p = 0;  // coefficient of s^j in Q_d(1+s) (1+s)^(2−d)
      for (int m = std::max(j - (2 - d), 0); m <= N; ++m)
        p += Q[d][m] * binom[m + 2 - d][j];
      if (j < order) {
        if (p != 0) return;  // cannot happen (Φ^(d) = O(s^order)); stay on the general path
        continue;
      }
      const double v = static_cast<double>(static_cast<long double>(p) / static_cast<long double>(D));
      if (!(v > 0)) return;  // a negative term could cancel: keep the general path
      r[4 * (j - order) + d] = v;
    }
  }
  for (int j = 0; j <= N; ++j) r[4 * j + 3] = static_cast<double>(binom[N][j]);
  static std::mutex mutex;
  static std::map<int, std::unique_ptr<Coefficients>> tables;  // key: 100 n + k
  const std::lock_guard<std::mutex> lock(mutex);
  auto& entry = tables[100 * n + k_];
  if (!entry) {
    entry = std::make_unique<Coefficients>();
    entry->c = r;
  }
  r_ = entry->c.data();
  static constexpr auto table = rational_table(std::make_integer_sequence<int, kMaxDegree + 2>{});
  rational_ = table[N + 1];
  rational_terms_ = N + 1;
}

// t = x^(−n), n = 1/h, by table (no rational form: 1/h not an integer), where the closed form
// is used for every term: above the series limit and outside E's expm1 bands. Nodes x_j are
// the doubles with `bits` significant bits from 1 up, so u = x/x_j − 1 ∈ [0, 2^(1−bits)); with
// max(n, 1) 2^(1−bits) <= 1/16 each term of Σ C(−n, i) u^i is at most 1/16 of the one before,
// and 16 terms leave < 2^−63 relative. Nodes x_j^(−n) from long double, as hi + lo: t within
// about an ulp (exp(−log1p(s)/h) carries ~n ln(x) ulp from the logarithm's rounding).
constexpr std::uint64_t kMaxPowerNodes = 2048;  // 3 doubles a node, 49 kB; h in [0.005, 1] needs ~1,900 at most

// For n = 1/h > 2, from where x^(2−n) <= 2^−56 every x^β of E is below half an ulp of 1, so x^β − 1
// is −1 exactly and (1 − t)^(k−1) is 1: t = 0 gives the same doubles, with no log1p or exp (the
// validator's far-field points, s ~ 10⁴ R, spent a third of a large hull's check on them).
// Also E's 1/β, for t = 0 and the table's range (β = 0 gives inf, never used: no table then).
void BaseFunction::set_power_zero(Series& table, double h, int k) {
  const long double n = 1.0L / h;
  for (int i = 1; i < k; ++i) {
    table.power_inverse_beta[2 * i - 2] = static_cast<double>(1 / (1 - i * n));
    table.power_inverse_beta[2 * i - 1] = static_cast<double>(1 / (2 - i * n));
  }
  if (!(n > 2)) return;
  table.power_zero = std::max(std::expm1(table.limit),  // above the series (which has no t)
                              std::nextafter(static_cast<double>(std::exp2(56 / (n - 2)) - 1), INFINITY));
}

void BaseFunction::build_power_table(Series& table, double h, int k) {
  const long double n = 1.0L / h;
  long double beta_min = INFINITY;
  for (int i = 1; i < k; ++i) beta_min = std::min({beta_min, std::abs(1 - i * n), std::abs(2 - i * n)});
  const int bits = 1 + static_cast<int>(std::ceil(std::log2(16 * std::max(n, 1.0L))));
  if (!(beta_min > 0) || bits > 16) return;  // β = 0 needs L; h < ~1/2000: a long table
  const double from = std::max(std::expm1(table.limit), static_cast<double>(std::expm1(0.5L / beta_min)));
  const double zero = std::max(from, table.power_zero);
  table.power_shift = 53 - bits;
  const auto bits_of = [](double v) { return std::bit_cast<std::uint64_t>(v); };
  const std::uint64_t base = bits_of(1.0) >> table.power_shift;
  const double x_end = std::min({1 + zero, 1024.0, std::bit_cast<double>((base + kMaxPowerNodes) << table.power_shift)});
  const std::uint64_t count = (bits_of(x_end) >> table.power_shift) - base + 1;  // + 1: x = 1 + s may round up to x_end
  table.power.resize(3 * count);
  for (std::uint64_t j = 0; j < count; ++j) {
    const long double xj = std::bit_cast<double>((base + j) << table.power_shift);
    const long double t = std::pow(xj, -n);
    table.power[3 * j] = static_cast<double>(t);
    table.power[3 * j + 1] = static_cast<double>(t - static_cast<double>(t));
    table.power[3 * j + 2] = static_cast<double>(1 / xj);
  }
  long double c = -n;  // C(−n, i + 1): q/u = Σ C(−n, i + 1) u^i
  for (int i = 0; i < Series::kPowerTerms; ++i) {
    table.power_binom[i] = static_cast<double>(c);
    c *= (-n - i - 1) / (i + 2);
  }
  table.power_from = from;
  table.power_to = x_end - 1;
  table.power_zero = zero;
}

// Built once per (h, k) for up to kMaxCachedSeries pairs (requests may name any h; past that
// each BaseFunction builds its own), then shared (up to ~49 kB each with the power table: ~13 MB in all).
constexpr std::size_t kMaxCachedSeries = 256;

std::shared_ptr<const BaseFunction::Series> BaseFunction::series_for(double h, int k, bool power_table) {
  static std::mutex mutex;
  static std::map<std::pair<double, int>, std::shared_ptr<const Series>> cache;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    if (const auto found = cache.find({h, k}); found != cache.end()) return found->second;
  }
  // Φ''(t) = (1 − e^(−t/h))^(k−1) as a series in t = L; its coefficients grow like
  // ((k−1)/h)^n/n!, so the series is used while u = (k−1) L / h <= series_limit_u(k) (and
  // L <= that limit); above it the closed form loses at most a few digits to cancellation.
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
  // Truncate where the next term is below 1e-19 at the series limit: coefficients decay like
  // w^n/n! with w the larger of u's limit and 2L (from the e^t, e^2t factors of Φ', Φ).
  auto series = std::make_shared<Series>();
  const double u_max = series_limit_u(k);
  series->limit = std::min(u_max, u_max * h / (k - 1));
  const double w = std::max(u_max, 2 * series->limit);
  int terms = 8;
  for (double bound = 1; terms < kSeriesTerms; ++terms) {
    bound = std::pow(w, terms) / std::tgamma(terms + 1.0);
    if (bound < 1e-19) break;
  }
  series->c0.assign(p0.begin(), p0.begin() + terms);
  series->c1.assign(p1.begin(), p1.begin() + terms);
  series->c2.assign(p.begin(), p.begin() + terms);
  set_power_zero(*series, h, k);
  if (power_table) build_power_table(*series, h, k);
  const std::lock_guard<std::mutex> lock(mutex);
  if (cache.size() < kMaxCachedSeries) cache.emplace(std::pair{h, k}, series);
  return series;
}

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
  build_rational_form();
  series_ = series_for(h, k, !rational_);
}

template <class T>
BaseFunction::JetT<T> BaseFunction::series(T L) const {
  // Three Horner chains interleaved (independent, so they pipeline).
  const std::vector<double>&c0 = series_->c0, &c1 = series_->c1, &c2 = series_->c2;
  const size_t n = c0.size();
  T v0 = c0[n - 1], v1 = c1[n - 1], v2 = c2[n - 1];
  for (size_t i = n - 1; i-- > 0;) {
    v0 = v0 * L + c0[i];
    v1 = v1 * L + c1[i];
    v2 = v2 * L + c2[i];
  }
  return {v0, v1, v2};
}

template <class T>
BaseFunction::JetT<T> BaseFunction::closed_form(T s, T t, const T* L) const {
  const T x = s + T(1);
  // i = 0 (a = 0): E(1) = s and E(2) = s(s + 2)/2 exactly, so its term is s²/2.
  JetT<T> j{binom_[0] * T(0.5) * s * s, binom_[0] * s, T(0)};
  T xa = t;  // x^(−i/h)
  const double* inverse_beta = series_->power_inverse_beta.data();
  for (int i = 1; i < k_; ++i) {
    T e1, e2;
    if (L) {
      const T a = i / T(h_);
      e1 = E<T>(T(1) - a, x * xa, *L);
      e2 = E<T>(T(2) - a, x * x * xa, *L);
    } else {  // the power table's range: every β is far from 0, and its reciprocal is kept
      e1 = (x * xa - T(1)) * inverse_beta[2 * i - 2];
      e2 = (x * x * xa - T(1)) * inverse_beta[2 * i - 1];
    }
    j.value += binom_[i] * (x * e1 - e2);
    j.d1 += binom_[i] * e1;
    xa *= t;
  }
  // Here L/h > 1/(k−1), so 1 − t has no cancellation.
  T d2 = 1;
  for (int i = 1; i < k_; ++i) d2 *= T(1) - t;
  j.d2 = d2;
  return j;
}

template <class T>
BaseFunction::JetT<T> BaseFunction::general_jet(T s) const {
  if constexpr (std::is_same_v<T, double>) {
    const Series& table = *series_;
    if (s >= table.power_zero) return closed_form<T>(s, 0.0, nullptr);
    if (s >= table.power_from && s < table.power_to) return closed_form<T>(s, power_from_table(table, s), nullptr);
  }
  const T L = std::log1p(s);
  return L <= series_->limit ? series(L) : closed_form(s, std::exp(-L / h_), &L);
}

double BaseFunction::power_from_table(const Series& table, double s) {
  const auto bits = [](double v) { return std::bit_cast<std::uint64_t>(v); };
  const std::uint64_t base = bits(1.0) >> table.power_shift;
  const std::uint64_t j = (bits(1 + s) >> table.power_shift) - base;
  const double sj = std::bit_cast<double>((base + j) << table.power_shift) - 1;  // exact
  const double* node = &table.power[3 * j];
  const double u = (s - sj) * node[2];  // x / x_j − 1, |u| < 2^(1 − bits)
  // q = (1+u)^(−n) − 1 by Estrin's scheme (a short dependency chain, as rational_form), then
  // t = x_j^(−n) (1 + q) with x_j^(−n) = hi + lo: its rounding and q's stay below 1/16 ulp.
  const auto& c = table.power_binom;
  const double u2 = u * u, u4 = u2 * u2, u8 = u4 * u4;
  double p[8];
  for (int i = 0; i < 8; ++i) p[i] = c[2 * i] + c[2 * i + 1] * u;
  for (int i = 0; i < 4; ++i) p[i] = p[2 * i] + p[2 * i + 1] * u2;
  for (int i = 0; i < 2; ++i) p[i] = p[2 * i] + p[2 * i + 1] * u4;
  const double q = u * (p[0] + p[1] * u8);
  return node[0] + (node[1] + node[0] * q);
}

template BaseFunction::JetT<double> BaseFunction::general_jet(double) const;
template BaseFunction::JetT<long double> BaseFunction::general_jet(long double) const;

}  // namespace distlab
