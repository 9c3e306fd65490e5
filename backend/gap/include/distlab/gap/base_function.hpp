#pragma once
// The base k-P2S function Φ of the GAP paper (Definition 4, eq. 4), for any integer k >= 2 and
// h > 0:  Φ''(s) = (1 − (s+1)^(−1/h))^(k−1) for s >= 0, and Φ(s) = 0 for s <= 0.
#include <vector>

namespace distlab {

class BaseFunction {
 public:
  static constexpr int kMaxK = 12;

  // Throws InvalidInput("params.h" / "params.k") for h <= 0 or not finite, k < 2 or k > kMaxK.
  BaseFunction(double h, int k);

  struct Jet {
    double value = 0, d1 = 0, d2 = 0;  // Φ, Φ', Φ''
  };
  Jet jet(double s) const;
  double value(double s) const { return jet(s).value; }

  double h() const { return h_; }
  int k() const { return k_; }

 private:
  Jet closed_form(double s, double L) const;
  Jet series(double L) const;

  double h_;
  int k_;
  std::vector<double> binom_;  // (−1)^i C(k−1, i), i = 0..k−1
  double series_limit_;        // L = ln(1+s) below which the series in L is used
  // Taylor coefficients in L = ln(1 + s) of Φ, Φ', Φ'' (all three are entire functions of L).
  std::vector<double> c0_, c1_, c2_;
};

}  // namespace distlab
