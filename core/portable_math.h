// Double-precision sine, cosine and arctangent from +, −, × and ÷ alone, so that their bits do not depend on the CPU:
// glibc picks an FMA variant of its double sin, cos and atan2 where the CPU has FMA, and the variants differ in the
// last bit for a few inputs in ten thousand (docs/architecture.md, "Determinism"). The reference's light sampling
// calls these once per sample, millions of times a frame, where a changed last bit could reach a float it writes.
// Accuracy: within a few units in the last place of libm's (tests/core/portable_math_test.cpp).
#pragma once

#include <cmath>

namespace restir {

// sin x and cos x for |x| ≤ 64: x less the nearest multiple k of π/2, with π/2 in two parts whose first has 33
// significant bits (so k × it is exact; fdlibm's split), then the Taylor series of the remainder (|r| ≤ π/4, terms
// to r²¹, truncation below 1e-22) by Horner's rule, and the quarter turns by swaps and signs.
inline void PortableSinCos(double x, double& sine, double& cosine) {
  constexpr double kTwoOverPi = 0.63661977236758134308;
  constexpr double kPiOver2Hi = 1.57079632673412561417e+00;  // the first 33 bits of π/2
  constexpr double kPiOver2Lo = 6.07710050650619224932e-11;  // π/2 less that
  const double k = std::floor(x * kTwoOverPi + 0.5);
  const double r = (x - k * kPiOver2Hi) - k * kPiOver2Lo;
  const double r2 = r * r;
  double s = 1.0 / 121645100408832000.0;  // 1/19!
  s = s * -r2 + 1.0 / 355687428096000.0;  // 1/17!
  s = s * -r2 + 1.0 / 1307674368000.0;    // 1/15!
  s = s * -r2 + 1.0 / 6227020800.0;       // 1/13!
  s = s * -r2 + 1.0 / 39916800.0;         // 1/11!
  s = s * -r2 + 1.0 / 362880.0;           // 1/9!
  s = s * -r2 + 1.0 / 5040.0;             // 1/7!
  s = s * -r2 + 1.0 / 120.0;              // 1/5!
  s = s * -r2 + 1.0 / 6.0;                // 1/3!
  s = r - r * r2 * s;
  double c = 1.0 / 2432902008176640000.0;  // 1/20!
  c = c * -r2 + 1.0 / 6402373705728000.0;  // 1/18!
  c = c * -r2 + 1.0 / 20922789888000.0;    // 1/16!
  c = c * -r2 + 1.0 / 87178291200.0;       // 1/14!
  c = c * -r2 + 1.0 / 479001600.0;         // 1/12!
  c = c * -r2 + 1.0 / 3628800.0;           // 1/10!
  c = c * -r2 + 1.0 / 40320.0;             // 1/8!
  c = c * -r2 + 1.0 / 720.0;               // 1/6!
  c = c * -r2 + 1.0 / 24.0;                // 1/4!
  c = c * -r2 + 0.5;                       // 1/2!
  c = 1.0 - r2 * c;
  const int quadrant = static_cast<int>(k - 4.0 * std::floor(k * 0.25));  // k mod 4, for negative k too
  switch (quadrant) {
    case 0: sine = s, cosine = c; break;
    case 1: sine = c, cosine = -s; break;
    case 2: sine = -s, cosine = -c; break;
    default: sine = -c, cosine = s; break;
  }
}

// atan t for t in [0, 1]: above tan(π/8), π/4 + atan((t − 1) / (t + 1)), so that the series runs on |s| ≤ tan(π/8)
// (s² ≤ 0.172; 24 terms leave less than 1e-19).
inline double PortableAtanUnit(double t) {
  constexpr double kTanPiOver8 = 0.41421356237309504880;
  constexpr double kPiOver4 = 0.78539816339744830962;
  const bool reduce = t > kTanPiOver8;
  const double s = reduce ? (t - 1.0) / (t + 1.0) : t;
  // 1 / (2n + 1) for n = 1 .. 23, each the double nearest (the constant expression's rounding).
  static constexpr double kInverseOdd[24] = {
      1.0,        1.0 / 3,  1.0 / 5,  1.0 / 7,  1.0 / 9,  1.0 / 11, 1.0 / 13, 1.0 / 15, 1.0 / 17, 1.0 / 19, 1.0 / 21, 1.0 / 23,
      1.0 / 25,   1.0 / 27, 1.0 / 29, 1.0 / 31, 1.0 / 33, 1.0 / 35, 1.0 / 37, 1.0 / 39, 1.0 / 41, 1.0 / 43, 1.0 / 45,
      1.0 / 47};
  const double s2 = s * s;
  double p = 0.0;
  for (int n = 23; n >= 1; --n) p = kInverseOdd[n] - s2 * p;
  const double a = s - s * s2 * p;
  return reduce ? kPiOver4 + a : a;
}

// atan2(y, x) in (−π, π], as libm's for finite arguments (0 where both are 0).
inline double PortableAtan2(double y, double x) {
  constexpr double kPi = 3.14159265358979323846;
  constexpr double kPiOver2 = 1.57079632679489661923;
  const double ax = std::fabs(x), ay = std::fabs(y);
  if (ax == 0.0 && ay == 0.0) return std::signbit(x) ? (std::signbit(y) ? -kPi : kPi) : (std::signbit(y) ? -0.0 : 0.0);
  double a = ay <= ax ? PortableAtanUnit(ay / ax) : kPiOver2 - PortableAtanUnit(ax / ay);
  if (std::signbit(x)) a = kPi - a;
  return std::signbit(y) ? -a : a;
}

}  // namespace restir
