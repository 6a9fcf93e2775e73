// Small sampling helpers the passes and the reference share (pbrt-v4's util/sampling.h in spirit): pure functions
// of their random numbers, each with its test in tests/core/sampling_test.cpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/math.h"
#include "core/rng.h"

namespace restir {

// sin(2πu) and cos(2πu) for u in [0, 1), with only +, -, * and selects, so that a SIMD lane reproduces them bit
// for bit (glibc's sincosf has no SIMD twin; core/bsdf_draw_kernel.cpp repeats this lane by lane): u = q/4 + r
// with q the nearest quarter turn and |r| <= 1/8 (exact in float), sin and cos of 2πr by polynomials in r² fitted
// here for absolute error about 1e-7 (this project's own minimax fit), then the quarter turns by swaps and signs.
inline void SinCos2Pi(float u, float& sine, float& cosine) {
  const float q = static_cast<float>(static_cast<int32_t>(4.0f * u + 0.5f));  // 4u >= 0: truncation rounds
  const float r = u - 0.25f * q;
  const float z = r * r;
  const float s = r * (((-75.40213012695312f * z + 81.5925521850586f) * z - 41.3416633605957f) * z +
                       6.2831854820251465f);
  const float c = ((-83.59269714355469f * z + 64.92125701904297f) * z - 19.739152908325195f) * z + 1.0f;
  const int32_t quarter = static_cast<int32_t>(q) & 3;
  sine = quarter == 0 ? s : quarter == 1 ? c : quarter == 2 ? -s : -c;
  cosine = quarter == 0 ? c : quarter == 1 ? -s : quarter == 2 ? -c : s;
}

// Offset of a uniform point in a disk of the given radius, by the polar map: r = radius sqrt(u0), φ = 2π u1. The
// spatial passes round it to a neighbouring pixel (DESIGN §4 "Spatial reuse", seed 004 §5.1's search positions).
inline Vec2 SampleUniformDiskPolar(float radius, float u0, float u1) {
  const float r = radius * std::sqrt(u0);
  const float phi = 2.0f * kPi * u1;
  return Vec2(r * std::cos(phi), r * std::sin(phi));
}

// A neighbour's pixel offset: SampleUniformDiskPolar's point with each coordinate rounded by std::lround, the same
// integers, without libm's sinf and cosf wherever the answer is already certain (sincosf was 1.9% of a profile of
// README command 1). SinCos2Pi is within 1e-6 of libm's sine and cosine of the float φ (tests/core/sampling_test.cpp
// checks it), so the point is within r·1e-6 of libm's and the rounding is decided wherever a coordinate lies more
// than (r + 1)·4e-6 from a half-integer; the rest, a fraction 8e-6·(r + 1) of coordinates (2.5e-4 at r = 30), is
// computed the defining way.
struct PixelOffset {
  int dx = 0, dy = 0;
  bool operator==(const PixelOffset&) const = default;
};
inline PixelOffset RoundedDiskOffset(float radius, float u0, float u1) {
  const float r = radius * std::sqrt(u0);
  if (u1 >= 0.0f && u1 < 1.0f && r >= 0.0f && r <= 1e4f) {
    float s, c;
    SinCos2Pi(u1, s, c);
    const float x = r * c, y = r * s;
    const float fx = std::floor(x), fy = std::floor(y);
    const float past = x - fx - 0.5f, pastY = y - fy - 0.5f;  // signed distance beyond the half-integer
    const float margin = (r + 1.0f) * 4e-6f;
    if (std::abs(past) > margin && std::abs(pastY) > margin)
      return {static_cast<int>(fx) + (past > 0.0f ? 1 : 0), static_cast<int>(fy) + (pastY > 0.0f ? 1 : 0)};
  }
  const Vec2 d = SampleUniformDiskPolar(radius, u0, u1);
  return {static_cast<int>(std::lround(d.x)), static_cast<int>(std::lround(d.y))};
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

// The probability SampleCdf returns index l: the step of the cdf it inverts, times 1 / the total (a product:
// the light-draw kernel broadcasts the reciprocal once per receiver instead of dividing every draw).
inline float CdfPmf(const float* cdf, size_t n, uint32_t l) {
  return (cdf[l] - (l ? cdf[l - 1] : 0.0f)) * (1.0f / cdf[n - 1]);
}

// The entry a cdf over groups of one or two entries gives u (the reference's light groups, core/light.h): the group
// g SampleCdf inverts u to, then its first entry, or its second where u's target falls in the top 1 - split[g] of
// the group's step (split[g] = 2: a lone entry). core/light_draw_kernel.cpp repeats it lane by lane.
inline uint32_t SampleSplitCdf(const float* cdf, size_t groups, const uint32_t* first, const float* split, float u) {
  const uint32_t g = SampleCdf(cdf, groups, u);
  const float target = u * cdf[groups - 1];
  const float before = g ? cdf[g - 1] : 0.0f;
  return first[g] + (target - before >= split[g] * (cdf[g] - before) ? 1u : 0u);
}

// frac(shift + k α) in 32-bit fixed point: the word shift + k alpha (mod 2^32, exact integer arithmetic) as a
// float in [0, 1), its top 24 bits scaled exactly (core/rng.h BitsToUnitFloat). With a uniformly random shift,
// every point is uniform over the 2^24 values a float uniform takes. One coordinate of a shifted Roberts sequence
// (below); core/qmc_kernel.cpp repeats it lane by lane.
inline float RobertsCoordinate(uint32_t shift, uint32_t k, uint32_t alpha) { return BitsToUnitFloat(shift + k * alpha); }

// Roberts' R_d low-discrepancy sequence in D dimensions (Roberts 2018, "The unreasonable effectiveness of
// quasirandom sequences"): point k is frac(shift + k α) with α_j = φ_d^-(j+1), φ_d the positive root of
// x^(D+1) = x + 1, here α_j rounded to 32 bits (a rank-1 lattice rule with that generator: for the point counts a
// pixel takes, far below 2^32, the same low discrepancy). Randomly shifted copies are independent replicates of a
// randomised QMC estimator (Owen 2013, "Monte Carlo theory, methods and examples", ch. 17), each of whose points
// is uniformly distributed.
template <int D>
struct RobertsSequence {
  uint32_t alpha[D];  // α_j × 2^32, rounded
  RobertsSequence() {
    double phi = 2.0;  // Newton from 2
    for (int i = 0; i < 64; ++i) phi -= (std::pow(phi, D + 1) - phi - 1.0) / ((D + 1) * std::pow(phi, D) - 1.0);
    for (int j = 0; j < D; ++j)
      alpha[j] = static_cast<uint32_t>(std::llround(std::ldexp(std::fmod(std::pow(1.0 / phi, j + 1), 1.0), 32)));
  }
  // Coordinate j of point k of the copy shifted by `shift`, as a float in [0, 1).
  float Coordinate(uint32_t shift, uint32_t k, int j) const { return RobertsCoordinate(shift, k, alpha[j]); }
};

}  // namespace restir
