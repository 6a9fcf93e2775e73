// core/sampling.h's cdf inversion and Roberts coordinates against independent forms: SampleCdf against a
// linear count of the entries at or below the target (std::upper_bound's definition, written out), on cdfs of
// 1 to 600 entries with zero steps, plateaus and twelve decades of step sizes, at random uniforms and at the
// cdf's own boundaries; CdfPmf against the measure of the uniforms SampleCdf maps to each index;
// RobertsCoordinate against std::fmod, which is exact.
#include "core/sampling.h"

#include <gtest/gtest.h>

#include <cmath>
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
      if (p == 0.0f) EXPECT_EQ(hits[l], 0.0) << "a zero step is never chosen";
    }
    EXPECT_NEAR(sum, 1.0, 1e-5);
  }
}

TEST(RobertsCoordinate, IsTheFractionalPartRoundedToFloatBelowOne) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> a(1e-6, 1.0);
  std::uniform_real_distribution<float> s(0.0f, 1.0f);
  const RobertsSequence<5> r5;
  for (int i = 0; i < 200000; ++i) {
    const double alpha = i % 10 < 5 ? r5.alpha[i % 5] : a(rng);
    const float shift = i % 97 == 0 ? 0.0f : i % 89 == 0 ? 0x1.fffffep-1f : s(rng);
    const int k = static_cast<int>(rng() % 65536);
    const double v = double(shift) + double(k) * alpha;
    const float expected = std::min(static_cast<float>(std::fmod(v, 1.0)), 0x1.fffffep-1f);
    const float got = RobertsCoordinate(shift, k, alpha);
    ASSERT_EQ(got, expected) << "shift " << shift << " k " << k << " alpha " << alpha;
    ASSERT_GE(got, 0.0f);
    ASSERT_LT(got, 1.0f);
    if (i % 10 < 5) ASSERT_EQ(got, r5.Coordinate(shift, k, i % 5));
  }
}

}  // namespace
}  // namespace restir
