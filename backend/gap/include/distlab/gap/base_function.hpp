#pragma once
// The base k-P2S function Φ of the GAP paper (Definition 4, eq. 4), for any integer k >= 2 and
// h > 0:  Φ''(s) = (1 − (s+1)^(−1/h))^(k−1) for s >= 0, and Φ(s) = 0 for s <= 0.
#include <array>
#include <cmath>
#include <memory>
#include <type_traits>
#include <vector>

namespace distlab {

class BaseFunction {
 public:
  static constexpr int kMaxK = 12;

  // Throws InvalidInput("params.h" / "params.k") for h <= 0 or not finite, k < 2 or k > kMaxK.
  BaseFunction(double h, int k);

  template <class T>
  struct JetT {
    T value = 0, d1 = 0, d2 = 0;  // Φ, Φ', Φ''
  };
  using Jet = JetT<double>;
  Jet jet(double s) const {
    if (!(s > 0)) return {};
    if (s <= kRationalMaxS) {
      // k = 2, h = 0.1 (the paper's parameters and the default) inline; others by table.
      if (rational_terms_ == 11) return rational_form<11>(s);
      if (rational_) return (this->*rational_)(s);
    }
    return general_jet(s);
  }
  double value(double s) const { return jet(s).value; }
  // Φ in a wider scalar T (long double: references without double's rounding, PointToSet::
  // strict_at): the general path, series or closed form, evaluated in T (its coefficients are
  // doubles, a smooth change of Φ far below the precision asked for). T = double: jet(s).
  template <class T>
  JetT<T> jet_as(T s) const {
    if constexpr (std::is_same_v<T, double>) return jet(s);
    else return s > 0 ? general_jet(s) : JetT<T>{};
  }

  double h() const { return h_; }
  int k() const { return k_; }
  // The same Φ (it depends on h and k alone).
  bool same_as(const BaseFunction& other) const { return h_ == other.h_ && k_ == other.k_; }

 private:
  // s > 0: series in ln(1+s) or closed form (T = double and long double, base_function.cpp).
  template <class T>
  JetT<T> general_jet(T s) const;
  // t = x^(−1/h); L = ln x, or null on the power table's range (past every expm1 band of E: power_from;
  // E then takes 1/β from the table).
  template <class T>
  JetT<T> closed_form(T s, T t, const T* L) const;
  template <class T>
  JetT<T> series(T L) const;
  void build_rational_form();

 public:
  // Internal (instantiated for every term count; selected once in the constructor).
  template <int T>
  Jet rational_form(double s) const;
  using RationalForm = Jet (BaseFunction::*)(double) const;

 private:
  double h_;
  int k_;
  std::vector<double> binom_;  // (−1)^i C(k−1, i), i = 0..k−1
  // Taylor coefficients in L = ln(1 + s) of Φ, Φ', Φ'' (all three are entire functions of L)
  // and the L below which the series is used. Built from long-double products of 60-term
  // series (~100 µs, 40 GAP solves), so once per (h, k) and shared (series_for in the .cpp).
  // Without a rational form (1/h not an integer), the closed form's t = (1+s)^(−1/h) comes from
  // a table on s ∈ [power_from, power_to) instead of exp(−log1p(s)/h) (base_function.cpp).
  struct Series {
    std::vector<double> c0, c1, c2;
    double limit = 0;
    // Nodes x_j = 1 + s_j: the doubles with b significant bits from 1 up (b from h, the .cpp);
    // x's node is j = (bits of x >> power_shift) − (bits of 1 >> power_shift), shift = 53 − b.
    static constexpr int kPowerTerms = 16;
    int power_shift = 0;
    double power_from = INFINITY, power_to = 0;     // the table's range (empty: from >= to)
    double power_zero = INFINITY;                   // from here t = 0 gives Φ's doubles exactly (any table)
    std::vector<double> power;                      // x_j^(−1/h) as hi + lo, 1/x_j: three a node
    std::array<double, kPowerTerms> power_binom{};  // C(−1/h, i + 1): (1+u)^(−1/h) = 1 + u Σ C(−1/h, i + 1) u^i
    // 1/β for the closed form's exponents β = 1 − i/h, 2 − i/h (i = 1..k−1), each rounded once:
    // on the table's range E(β) = (x^β − 1)/β takes a product instead of a division.
    std::array<double, 2 * (kMaxK - 1)> power_inverse_beta{};
  };
  std::shared_ptr<const Series> series_;
  static std::shared_ptr<const Series> series_for(double h, int k, bool power_table);
  static void set_power_zero(Series& table, double h, int k);
  static void build_power_table(Series& table, double h, int k);
  static double power_from_table(const Series& table, double s);

  // When n = 1/h is an integer (3 <= n, (k−1) n <= kMaxDegree), Φ^(d) is a rational function of
  // s without cancellation: Φ^(d)(s) = s^(k+1−d) P_d(s) / (1+s)^N, N = (k−1) n, where the
  // polynomials P_d have positive coefficients (base_function.cpp). No log1p/exp, no series.
  static constexpr int kMaxDegree = 20;
  static constexpr double kRationalMaxS = 1e3;  // beyond it the closed form (no cancellation)
  RationalForm rational_ = nullptr;             // null: not available for this (h, k)
  int rational_terms_ = 0;                      // N + 1 when rational_ is set
  // P_0, P_1, P_2 and (1+s)^N interleaved: r_[4 i + d] is the coefficient of s^i (.cpp). One
  // table per (n, k), shared by every BaseFunction with those parameters and kept to the end
  // of the program (at most a few dozen exist), so many shapes with the same h and k keep one table in cache.
  struct alignas(16) Coefficients {
    std::array<double, 4 * (kMaxDegree + 1)> c{};
  };
  const double* r_ = nullptr;
};

// Φ, Φ', Φ'' from the rational form, with L coefficients per polynomial (known at compile
// time, so the evaluation is unrolled; the four polynomials pair into SIMD lanes).
template <int L>
inline BaseFunction::Jet BaseFunction::rational_form(double s) const {
  // Estrin's scheme: x_{2i} + x_{2i+1} t pairwise, t squared each level, so the dependency
  // chain is log2(L) multiply-adds long instead of Horner's L − 1 (the solver's P2S evaluations
  // wait on it). All terms are positive at s > 0: at most ~6 ulp (Horner's longer chain: 9), and
  // the one division adds half an ulp (test RationalFormIsWithinAFewUlpOfTheClosedForm).
  // Lanes (P_0, P_1) and (P_2, (1+s)^N) as two-double vectors (GCC vector extension: SSE2
  // on x86-64, plain code elsewhere).
  typedef double V2 __attribute__((vector_size(16)));
  if constexpr (L < 1) return {};  // not a polynomial (table slot never selected)
  else {
    const V2* c = reinterpret_cast<const V2*>(r_);
    V2 t = {s, s};
    V2 a[L], b[L];
#pragma GCC unroll 32
    for (int i = 0; i < L; ++i) a[i] = c[2 * i], b[i] = c[2 * i + 1];
#pragma GCC unroll 8
    for (int n = L; n > 1; n = (n + 1) / 2) {
#pragma GCC unroll 16
      for (int i = 0; i < n / 2; ++i) {
        a[i] = a[2 * i] + a[2 * i + 1] * t;
        b[i] = b[2 * i] + b[2 * i + 1] * t;
      }
      if (n % 2) a[n / 2] = a[n - 1], b[n / 2] = b[n - 1];
      t = t * t;
    }
    const double v0 = a[0][0], v1 = a[0][1], v2 = b[0][0], x = b[0][1];
    double q = 1.0 / x;                   // (1+s)^−N
    for (int j = 1; j < k_; ++j) q *= s;  // s^(k−1) (1+s)^−N
    return Jet{q * (s * s * v0), q * (s * v1), q * v2};
  }
}

}  // namespace distlab
