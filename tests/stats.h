// Statistical helpers for Monte Carlo tests. Every test states its false-failure rate; with a fixed seed the
// outcome is deterministic, so a failure means the distribution changed, not bad luck on this run.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

namespace restir::test {

// Upper quantile z of the standard normal for a one-sided tail probability, by bisection on erfc: exact to
// ~1e-10 and dependency-free.
inline double NormalQuantileUpper(double tail) {
  double lo = 0.0, hi = 40.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    const double p = 0.5 * std::erfc(mid / std::sqrt(2.0));
    (p > tail ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Regularized incomplete beta function I_x(a, b), by its continued fraction (modified Lentz), using the
// symmetry I_x(a, b) = 1 - I_{1-x}(b, a) where the fraction converges slowly.
inline double IncompleteBeta(double x, double a, double b) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  if (x > (a + 1.0) / (a + b + 2.0)) return 1.0 - IncompleteBeta(1.0 - x, b, a);
  const double lnFront = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  const double tiny = 1e-300;
  double c = 1.0, d = 1.0 - (a + b) * x / (a + 1.0);
  d = 1.0 / (std::fabs(d) < tiny ? tiny : d);
  double f = d;
  for (int m = 1; m < 1000; ++m) {
    for (int half = 0; half < 2; ++half) {
      const double num = half == 0 ? m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m))
                                   : -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
      d = 1.0 + num * d;
      d = 1.0 / (std::fabs(d) < tiny ? tiny : d);
      c = 1.0 + num / c;
      if (std::fabs(c) < tiny) c = tiny;
      f *= c * d;
      if (half == 1 && std::fabs(c * d - 1.0) < 1e-15) return std::exp(lnFront) * f / a;
    }
  }
  return std::exp(lnFront) * f / a;
}

// P(|T| > t) for Student's t with `dof` degrees of freedom.
inline double StudentTTwoSidedTail(double t, double dof) {
  return IncompleteBeta(dof / (dof + t * t), 0.5 * dof, 0.5);
}

// The t with P(|T| > t) = tail, by bisection.
inline double StudentTQuantileTwoSided(double tail, double dof) {
  double lo = 0.0, hi = 1e6;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (StudentTTwoSidedTail(mid, dof) > tail ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Moments of T² for Student's t (dof > 4): E = ν/(ν-2), Var = 2ν²(ν-1)/((ν-2)²(ν-4)).
inline double StudentTSquaredMean(double dof) { return dof / (dof - 2.0); }
inline double StudentTSquaredVariance(double dof) {
  return 2.0 * dof * dof * (dof - 1.0) / ((dof - 2.0) * (dof - 2.0) * (dof - 4.0));
}

// Upper critical value of chi-square with k degrees of freedom at tail probability `tail`
// (Wilson–Hilferty cube approximation; within 1% for k >= 10).
inline double ChiSquareCritical(int k, double tail) {
  const double z = NormalQuantileUpper(tail);
  const double h = 2.0 / (9.0 * k);
  const double c = 1.0 - h + z * std::sqrt(h);
  return k * c * c * c;
}

// Pearson chi-square statistic of observed counts against expected counts; bins with expected < 5 are pooled
// into one (a standard rule) before the statistic is formed. Returns the statistic and the degrees of freedom.
struct ChiSquareResult {
  double statistic = 0.0;
  int dof = 0;
};
inline ChiSquareResult ChiSquare(const std::vector<double>& observed, const std::vector<double>& expected) {
  ChiSquareResult r;
  double pooledObs = 0.0, pooledExp = 0.0;
  int bins = 0;
  for (size_t i = 0; i < observed.size(); ++i) {
    if (expected[i] < 5.0) {
      pooledObs += observed[i];
      pooledExp += expected[i];
      continue;
    }
    const double d = observed[i] - expected[i];
    r.statistic += d * d / expected[i];
    ++bins;
  }
  if (pooledExp >= 5.0) {
    const double d = pooledObs - pooledExp;
    r.statistic += d * d / pooledExp;
    ++bins;
  } else if (pooledObs > 0.0 && pooledExp == 0.0) {
    r.statistic = INFINITY;  // mass where none may be
  }
  r.dof = bins - 1;
  return r;
}

// The band for the mean of z² over k independent pixels, z = (a − b) / sqrt(se_a² + se_b²), each side's standard
// error from 16 replicates (15 dof). Were one side exact, z would be Student t with 15 dof and z² F(1, 15): mean
// 15/13, variance 3.389. With both estimated, z is a Welch statistic whose square has mean between 30/28 (equal
// variances; about t with 30 dof) and 15/13 (one side dominating), and variance at most F(1, 15)'s. So the band is
// [30/28 − c s, 15/13 + c s], s = sqrt(3.389 / k), c = 3.719 (the normal's one-sided 1e-4 quantile): false-failure
// rate at most 1e-4 on each side, 2e-4 in all, by the normal approximation of the mean (k >= 100; F(1, 15) is
// skewed, so the upper tail's true rate is somewhat above nominal).
struct Band {
  double lo = 0.0, hi = 0.0;
};
inline Band WelchZ2Band(int k) {
  const double c = NormalQuantileUpper(1e-4), s = std::sqrt(3.389 / k);
  return {30.0 / 28.0 - c * s, 15.0 / 13.0 + c * s};
}

// Running mean and variance (Welford), for t-tests of sample means.
struct RunningStats {
  double n = 0, mean = 0, m2 = 0;
  void Add(double x) {
    n += 1;
    const double d = x - mean;
    mean += d / n;
    m2 += d * (x - mean);
  }
  double Variance() const { return n > 1 ? m2 / (n - 1) : 0.0; }
  double StdError() const { return std::sqrt(Variance() / n); }
};

}  // namespace restir::test
