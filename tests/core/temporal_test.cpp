// The temporal guards of core/temporal.h on a grid of cases, edges included: the confidence cap of seed 003 §4.3
// and the target-ratio clamp of seed 003 §5 (bounds 0.1 and 10 inclusive; zero, negative, NaN and infinite targets
// rejected). Deterministic checks: exact equality, no tolerance.
#include "core/temporal.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>

namespace restir {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(CappedHistoryConfidence, IsTheSmallerOfConfidenceAndCap) {
  struct Case {
    float confidence, maxHistory, expected;
  };
  const Case cases[] = {
      {0.0f, 20.0f, 0.0f},          // no history
      {1.0f, 20.0f, 1.0f},          // under the cap: unchanged
      {19.5f, 20.0f, 19.5f},
      {20.0f, 20.0f, 20.0f},        // at the cap
      {std::nextafter(20.0f, kInf), 20.0f, 20.0f},  // just over: capped
      {50.0f, 20.0f, 20.0f},
      {1e30f, 20.0f, 20.0f},
      {kInf, 20.0f, 20.0f},
      {7.0f, 0.0f, 0.0f},           // a cap of 0 drops the history's weight
      {7.0f, kInf, 7.0f},           // no cap
      {-1.0f, 20.0f, -1.0f},        // not the cap's business: passed through
      {32.0f, 640.0f, 32.0f},       // confidences counting candidates (initial.countCandidates)
      {700.0f, 640.0f, 640.0f},
  };
  for (const Case& c : cases)
    EXPECT_EQ(CappedHistoryConfidence(c.confidence, c.maxHistory), c.expected)
        << c.confidence << " capped at " << c.maxHistory;
}

TEST(CappedHistoryConfidence, KeepsStdMinsOrderForNaN) {
  // Callers reject non-finite reservoirs first (FiniteReservoir); the order is pinned so the bits never change.
  EXPECT_TRUE(std::isnan(CappedHistoryConfidence(kNaN, 20.0f)));
  EXPECT_EQ(CappedHistoryConfidence(5.0f, kNaN), 5.0f);
}

TEST(TargetRatioInRange, AcceptsRatiosFromATenthToTenInclusive) {
  struct Case {
    float current, previous;
    bool expected;
  };
  const Case cases[] = {
      {1.0f, 1.0f, true},                                  // unchanged target
      {0.1f, 1.0f, true},                                  // ratio exactly 0.1
      {10.0f, 1.0f, true},                                 // ratio exactly 10
      {1.0f, 10.0f, true},                                 // 1/10 rounds to 0.1f: the bound
      {std::nextafter(0.1f, 0.0f), 1.0f, false},           // just under 0.1
      {std::nextafter(10.0f, kInf), 1.0f, false},          // just over 10
      {0.05f, 1.0f, false},
      {11.0f, 1.0f, false},
      {3.0f, 0.5f, true},                                  // ratio 6
      {0.3f, 2.0f, true},                                  // ratio 0.15
      {2e-30f, 1e-30f, true},                              // tiny targets: only the ratio matters
      {2e30f, 1e30f, true},                                // large targets
      {0.0f, 1.0f, false},                                 // current target 0
      {-1.0f, 1.0f, false},                                // negative current target
      {1.0f, 0.0f, false},                                 // previous target 0: ratio taken as 0
      {1.0f, -1.0f, false},                                // negative previous target
      {-1.0f, -1.0f, false},                               // both negative: ratio 1 is not computed
      {kNaN, 1.0f, false},                                 // NaN current target
      {1.0f, kNaN, false},                                 // NaN previous target
      {kInf, 1.0f, false},                                 // infinite ratio
      {1.0f, kInf, false},                                 // ratio 0
      {kInf, kInf, false},                                 // NaN ratio
      {1.0f, std::numeric_limits<float>::denorm_min(), false},  // overflows to inf
  };
  for (const Case& c : cases)
    EXPECT_EQ(TargetRatioInRange(c.current, c.previous), c.expected) << c.current << " / " << c.previous;
}

TEST(TargetRatioInRange, AcceptsWithinADecadeOnAGrid) {
  // Every (current, previous) of a grid of positive targets 10^(a/10) over six decades: the ratio is 10^((a-b)/10),
  // inside [0.1, 10] when |a - b| < 10 and outside when |a - b| > 10, far from the bounds either way (a factor
  // 10^0.1 = 1.26 against float rounding); |a - b| = 10 lands on a bound, which the table above covers exactly.
  for (int a = -30; a <= 30; ++a)
    for (int b = -30; b <= 30; ++b) {
      if (std::abs(a - b) == 10) continue;
      const float current = std::pow(10.0f, 0.1f * static_cast<float>(a));
      const float previous = std::pow(10.0f, 0.1f * static_cast<float>(b));
      EXPECT_EQ(TargetRatioInRange(current, previous), std::abs(a - b) < 10) << a << " " << b;
    }
}

}  // namespace
}  // namespace restir
