// Small sampling helpers the passes and the reference share (pbrt-v4's util/sampling.h in spirit): pure functions
// of their random numbers, each with its test in tests/core/sampling_test.cpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/math.h"

namespace restir {

// Offset of a uniform point in a disk of the given radius, by the polar map: r = radius sqrt(u0), φ = 2π u1. The
// spatial passes round it to a neighbouring pixel (DESIGN §4 "Spatial reuse", seed 004 §5.1's search positions).
inline Vec2 SampleUniformDiskPolar(float radius, float u0, float u1) {
  const float r = radius * std::sqrt(u0);
  const float phi = 2.0f * kPi * u1;
  return Vec2(r * std::cos(phi), r * std::sin(phi));
}

// Veach's power heuristic with β = 2 for one sample from each of two strategies (Veach 1997 §9.2.1):
// w_a = p_a² / (p_a² + p_b²); 0 when both densities are 0.
inline float PowerHeuristic(float a, float b) {
  const float a2 = a * a, b2 = b * b;
  return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

// Inverts a cumulative distribution: the index of the first of cdf[0, n) above u cdf[n - 1], for u in [0, 1)
// (cdf non-decreasing, cdf[n - 1] > 0), so a stratified u stays stratified across the indices. Branch-free
// binary search (std::upper_bound's branches mispredict on random u): lo counts the entries <= the target,
// kept in [lo, lo + len] while len halves. Where rounding puts the target at the total, the last index is
// returned whatever its probability (CdfPmf is then 0 there, and the caller must give the draw no value).
// core/light_draw_kernel.cpp repeats it lane by lane.
inline uint32_t SampleCdf(const float* cdf, size_t n, float u) {
  const float target = u * cdf[n - 1];
  size_t lo = 0, len = n;
  while (len > 1) {
    const size_t half = len / 2;
    lo = cdf[lo + half - 1] <= target ? lo + half : lo;
    len -= half;
  }
  return static_cast<uint32_t>(std::min(lo + (cdf[lo] <= target ? 1 : 0), n - 1));
}

// The probability SampleCdf returns index l: the step of the cdf it inverts, so selection and pmf agree bit
// for bit.
inline float CdfPmf(const float* cdf, size_t n, uint32_t l) {
  return (cdf[l] - (l ? cdf[l - 1] : 0.0f)) / cdf[n - 1];
}

// frac(shift + k alpha) as a float in [0, 1), for shift in [0, 1) and alpha > 0: one coordinate of a shifted
// Roberts sequence (below). core/qmc_kernel.cpp repeats it lane by lane.
inline float RobertsCoordinate(double shift, int k, double alpha) {
  const double v = shift + double(k) * alpha;
  // v >= 0, so truncation is floor: the same bits without a libm call on targets without SSE4.1's roundsd.
  return std::min(static_cast<float>(v - static_cast<double>(static_cast<int64_t>(v))), 0x1.fffffep-1f);
}

// Roberts' R_d low-discrepancy sequence in D dimensions (Roberts 2018, "The unreasonable effectiveness of
// quasirandom sequences"): point k is frac(shift + k α) with α_j = φ_d^-(j+1), φ_d the positive root of
// x^(D+1) = x + 1. Randomly shifted copies are independent replicates of a randomised QMC estimator (Owen 2013,
// "Monte Carlo theory, methods and examples", ch. 17), each of whose points is uniformly distributed.
template <int D>
struct RobertsSequence {
  double alpha[D];
  RobertsSequence() {
    double phi = 2.0;  // Newton from 2
    for (int i = 0; i < 64; ++i) phi -= (std::pow(phi, D + 1) - phi - 1.0) / ((D + 1) * std::pow(phi, D) - 1.0);
    for (int j = 0; j < D; ++j) alpha[j] = std::fmod(std::pow(1.0 / phi, j + 1), 1.0);
  }
  // Coordinate j of point k of the copy shifted by `shift`, as a float in [0, 1).
  float Coordinate(double shift, int k, int j) const { return RobertsCoordinate(shift, k, alpha[j]); }
};

}  // namespace restir
