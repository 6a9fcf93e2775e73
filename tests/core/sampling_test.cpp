// core/sampling.h's cdf inversion and Roberts coordinates against independent forms: SampleCdf against a
// linear count of the entries at or below the target (std::upper_bound's definition, written out), on cdfs of
// 1 to 600 entries with zero steps, plateaus and twelve decades of step sizes, at random uniforms and at the
// cdf's own boundaries; CdfPmf against the measure of the uniforms SampleCdf maps to each index;
// RobertsCoordinate against the same fixed-point sum in 64-bit integers, and the sequence's generators against
// an independent root of its polynomial; RoundedDiskOffset against its definition (the polar point, std::cos and
// std::sin, std::lround) at random points and at points built to sit on a rounding boundary.
#include "core/sampling.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace restir {
namespace {

std::vector<float> RandomCdf(std::mt19937& rng, size_t n) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> w(n);
  for (double& v : w) v = u(rng) < 0.25 ? 0.0 : std::pow(10.0, -6.0 + 12.0 * u(rng));
  w[rng() % n] += 1.0;  // a positive total
  double total = 0.0, running = 0.0;
  for (double v : w) total += v;
  std::vector<float> cdf;
  for (double v : w) cdf.push_back(static_cast<float>((running += v) / total));
  return cdf;
}

// The count of entries <= u * total, capped at n - 1: the first entry above the target.
uint32_t LinearInverse(const std::vector<float>& cdf, float u) {
  const float target = u * cdf.back();
  size_t count = 0;
  for (float c : cdf) count += c <= target ? 1 : 0;
  return static_cast<uint32_t>(std::min(count, cdf.size() - 1));
}

TEST(SampleCdf, IsTheFirstEntryAboveTheTarget) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  size_t checked = 0;
  for (size_t n : {1, 2, 3, 4, 5, 7, 8, 9, 31, 32, 33, 72, 100, 255, 256, 257, 600}) {
    for (int trial = 0; trial < 20; ++trial) {
      const std::vector<float> cdf = RandomCdf(rng, n);
      std::vector<float> us{0.0f, 0x1.fffffep-1f};
      for (float c : cdf)
        for (float b : {c / cdf.back(), std::nextafter(c / cdf.back(), 0.0f)})
          us.push_back(std::min(b, 0x1.fffffep-1f));
      for (int i = 0; i < 200; ++i) us.push_back(u(rng));
      for (float x : us) {
        const uint32_t l = SampleCdf(cdf.data(), n, x);
        ASSERT_EQ(l, LinearInverse(cdf, x)) << "n " << n << " u " << x;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 100000u);
}

TEST(CdfPmf, IsTheMeasureOfTheUniformsMappedToEachIndex) {
  std::mt19937 rng(2);
  constexpr int kGrid = 1 << 20;
  for (size_t n : {1, 2, 5, 72, 300}) {
    const std::vector<float> cdf = RandomCdf(rng, n);
    std::vector<double> hits(n, 0.0);
    for (int i = 0; i < kGrid; ++i) hits[SampleCdf(cdf.data(), n, (float(i) + 0.5f) / kGrid)] += 1.0;
    double sum = 0.0;
    for (uint32_t l = 0; l < n; ++l) {
      const float p = CdfPmf(cdf.data(), n, l);
      sum += p;
      // Each step of the grid is 2^-20; rounding of u * total moves a boundary by at most one float.
      EXPECT_NEAR(hits[l] / kGrid, p, 2.0 / kGrid + 1e-6) << "n " << n << " index " << l;
      if (p == 0.0f) { EXPECT_EQ(hits[l], 0.0) << "a zero step is never chosen"; }
    }
    EXPECT_NEAR(sum, 1.0, 1e-5);
  }
}

// SampleSplitCdf over groups of one or two entries: each entry is chosen for the measure of uniforms its group's
// step times its share of it (split, or 1 - split for a second entry; 1 for a lone one), and a lone entry's split
// of 2 never reaches past it.
TEST(SampleSplitCdf, ChoosesEachEntryWithItsShareOfItsGroupsStep) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> unit(0.05f, 0.95f);
  constexpr int kGrid = 1 << 20;
  for (size_t groups : {1, 2, 5, 36, 300}) {
    const std::vector<float> cdf = RandomCdf(rng, groups);
    std::vector<uint32_t> first;
    std::vector<float> split;
    uint32_t entries = 0;
    for (size_t g = 0; g < groups; ++g) {
      first.push_back(entries);
      const bool pair = rng() % 2 == 0;
      split.push_back(pair ? unit(rng) : 2.0f);
      entries += pair ? 2 : 1;
    }
    std::vector<double> hits(entries, 0.0);
    for (int i = 0; i < kGrid; ++i)
      hits[SampleSplitCdf(cdf.data(), groups, first.data(), split.data(), (float(i) + 0.5f) / kGrid)] += 1.0;
    for (size_t g = 0; g < groups; ++g) {
      const double p = CdfPmf(cdf.data(), groups, static_cast<uint32_t>(g));
      const bool pair = split[g] <= 1.0f;
      // Two float boundaries per entry, each within a grid step of 2^-20.
      EXPECT_NEAR(hits[first[g]] / kGrid, pair ? p * split[g] : p, 3.0 / kGrid + 1e-6) << "group " << g;
      if (pair) { EXPECT_NEAR(hits[first[g] + 1] / kGrid, p * (1.0 - split[g]), 3.0 / kGrid + 1e-6) << "group " << g; }
    }
  }
}

// The coordinate is frac(shift / 2^32 + k alpha / 2^32) truncated to 24 bits, computed here in 64-bit integers.
TEST(RobertsCoordinate, IsTheFractionalPartOfTheFixedPointSumTruncatedTo24Bits) {
  std::mt19937 rng(3);
  const RobertsSequence<5> r5;
  for (int i = 0; i < 200000; ++i) {
    const uint32_t alpha = i % 10 < 5 ? r5.alpha[i % 5] : static_cast<uint32_t>(rng());
    const uint32_t shift = i % 97 == 0 ? 0u : i % 89 == 0 ? ~0u : static_cast<uint32_t>(rng());
    const uint32_t k = static_cast<uint32_t>(rng() % 65536);
    const uint64_t word = (uint64_t{shift} + uint64_t{k} * alpha) % (uint64_t{1} << 32);
    const float expected = static_cast<float>(static_cast<double>(word >> 8) / 16777216.0);
    const float got = RobertsCoordinate(shift, k, alpha);
    ASSERT_EQ(got, expected) << "shift " << shift << " k " << k << " alpha " << alpha;
    ASSERT_GE(got, 0.0f);
    ASSERT_LT(got, 1.0f);
    if (i % 10 < 5) { ASSERT_EQ(got, r5.Coordinate(shift, k, i % 5)); }
  }
}

// The generators are Roberts' α_j = φ_d^-(j+1) to 32 bits, φ_d found here by bisection in long double on
// x^(d+1) = x + 1 (the golden ratio for d = 1).
TEST(RobertsSequence, GeneratorsArePowersOfTheGeneralisedGoldenRatio) {
  const auto check = [](const auto& seq, int d) {
    long double lo = 1.0L, hi = 2.0L;
    for (int i = 0; i < 200; ++i) {
      const long double mid = 0.5L * (lo + hi);
      (std::pow(mid, d + 1) - mid - 1.0L > 0.0L ? hi : lo) = mid;
    }
    for (int j = 0; j < d; ++j) {
      const long double exact = std::pow(1.0L / lo, j + 1) * 4294967296.0L;
      EXPECT_LE(std::fabs(static_cast<long double>(seq.alpha[j]) - exact), 0.5L + 1e-6L) << "d " << d << " j " << j;
    }
  };
  check(RobertsSequence<1>(), 1);
  check(RobertsSequence<5>(), 5);
  check(RobertsSequence<7>(), 7);
  EXPECT_EQ(RobertsSequence<1>().alpha[0], 2654435769u);  // 2^32 / φ, the golden ratio's well-known word
}

// The definition the spatial passes had inlined: the polar point, each coordinate rounded half away from zero.
PixelOffset DefinedDiskOffset(float radius, float u0, float u1) {
  const float r = radius * std::sqrt(u0);
  const float phi = 2.0f * kPi * u1;
  return {static_cast<int>(std::lround(r * std::cos(phi))), static_cast<int>(std::lround(r * std::sin(phi)))};
}

// The premise of the fast path: SinCos2Pi(u) within 1e-6 of libm's cosf and sinf of the float 2πu, a quarter of
// the margin RoundedDiskOffset allows per unit of radius.
TEST(RoundedDiskOffset, SinCos2PiStaysWithinAQuarterOfTheMarginOfLibm) {
  float worst = 0.0f;
  for (uint32_t bits = 0; bits < std::bit_cast<uint32_t>(1.0f); bits += 331) {
    const float u = std::bit_cast<float>(bits), phi = 2.0f * kPi * u;
    float s, c;
    SinCos2Pi(u, s, c);
    worst = std::max({worst, std::abs(s - std::sin(phi)), std::abs(c - std::cos(phi))});
  }
  EXPECT_LT(worst, 1e-6f);
}

TEST(RoundedDiskOffset, EqualsTheRoundedPolarPointAtRandomPoints) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (float radius : {0.0f, 0.5f, 1.0f, 2.5f, 30.0f, 64.0f, 350.0f, 3000.0f, 2e4f}) {
    for (int k = 0; k < 400000; ++k) {
      const float u0 = u(rng), u1 = u(rng);
      ASSERT_EQ(RoundedDiskOffset(radius, u0, u1), DefinedDiskOffset(radius, u0, u1))
          << "radius " << radius << " u0 " << u0 << " u1 " << u1;
    }
    for (float u0 : {0.0f, 1.0f, 0.25f})
      for (float u1 : {0.0f, 0.125f, 0.25f, 0.5f, 0.75f, std::nextafter(1.0f, 0.0f)})
        ASSERT_EQ(RoundedDiskOffset(radius, u0, u1), DefinedDiskOffset(radius, u0, u1)) << radius << " " << u1;
  }
}

// Points whose x or y coordinate lands within a few ulps of a half-integer, where the fast path must give way:
// u0 chosen so that r |cos φ| (or r |sin φ|) is k + 1/2, then every float of u0 within 48 ulps of it.
TEST(RoundedDiskOffset, EqualsTheRoundedPolarPointOnRoundingBoundaries) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int compared = 0;
  for (float radius : {1.0f, 3.0f, 30.0f, 350.0f}) {
    for (int trial = 0; trial < 3000; ++trial) {
      const float u1 = u(rng);
      const double phi = 2.0 * 3.14159265358979323846 * double(u1);
      const double along = trial % 2 ? std::abs(std::cos(phi)) : std::abs(std::sin(phi));
      const int maxK = static_cast<int>(radius * along - 0.5);
      if (maxK < 0 || along < 1e-3) continue;
      const double target = (static_cast<int>(u(rng) * float(maxK + 1)) + 0.5) / (double(radius) * along);
      const float u0 = static_cast<float>(target * target);
      if (!(u0 <= 1.0f)) continue;
      for (int d = -48; d <= 48; ++d) {
        const float v = std::bit_cast<float>(static_cast<uint32_t>(int64_t(std::bit_cast<uint32_t>(u0)) + d));
        if (!(v >= 0.0f && v <= 1.0f)) continue;
        ASSERT_EQ(RoundedDiskOffset(radius, v, u1), DefinedDiskOffset(radius, v, u1))
            << "radius " << radius << " u0 " << v << " u1 " << u1;
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 400000);
}

}  // namespace
}  // namespace restir
