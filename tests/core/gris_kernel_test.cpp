// The GRIS-combination kernel (core/gris_kernel.h): on every SIMD target this machine supports, and in the scalar
// twin, every combination of a batch gives what core/gris.h GrisCombine (or GrisResample) gives for it alone,
// bit for bit (DESIGN §3; NaN outputs are canonical), on random batches full of hard cases: zero, negative, NaN
// and infinite weights and targets, zero confidences, empty inputs, all-zero weights, overflowing weights,
// rows of zero targets, input counts 0..16 mixed within a packet, batch sizes around the vector widths, and
// matrix entries GrisCombine never reads filled with garbage.
#include "core/gris_kernel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "core/gris.h"
#include "core/simd.h"

#include "core/kernel_test_support.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace gris_kernel_test {

using test::Bits;
using test::Canonical;
using test::kInf;
using test::kNaN;

constexpr MisFamily kFamilies[] = {MisFamily::kUniform, MisFamily::kZ, MisFamily::kBalance, MisFamily::kPairwise,
                                   MisFamily::kStochasticPairwise};
constexpr VisibilityCarry kCarries[] = {VisibilityCarry::kSelected, VisibilityCarry::kWeighted};

const char* Name(VisibilityCarry c) { return c == VisibilityCarry::kWeighted ? "weighted" : "selected"; }

class GrisKernel : public test::SimdTargetTest {};


// How a combination's values are drawn.
enum class Regime { kClean, kHard, kAllZeroW, kOverflow, kZeroRows };

// What the entries of the target matrix that GrisCombine does not read are set to.
enum class Unread { kAsDrawn, kZero, kNaN, kWild };

struct Batch : GrisBatchArrays {
  std::vector<uint8_t> read;  // per target entry: GrisCombine read it (for the family last marked)
};

class Gen {
 public:
  explicit Gen(uint32_t seed) : rng_(seed) {}
  std::mt19937& Rng() { return rng_; }
  float Uniform() { return std::uniform_real_distribution<float>(0.0f, 1.0f)(rng_); }
  bool Chance(float p) { return Uniform() < p; }
  template <size_t n>
  float OneOf(const float (&v)[n]) { return v[rng_() % n]; }
  float LogUniform(float lo, float hi) { return lo * std::pow(hi / lo, Uniform()); }

  float Weight(bool hard) {  // W_i
    static const float kHard[] = {0.0f, -0.0f, -1.5f, kNaN, kInf, -kInf, 1e30f, 1e-40f, 3e38f};
    return hard && Chance(0.35f) ? OneOf(kHard) : LogUniform(1e-3f, 1e2f);
  }
  float Confidence(bool hard) {  // c_i
    static const float kHard[] = {0.0f, 0.0f, -0.0f, 1e30f, kNaN, kInf, -1.0f, 1e-40f};
    if (hard && Chance(0.2f)) return OneOf(kHard);
    return Chance(0.7f) ? static_cast<float>(1 + rng_() % 20) : LogUniform(0.05f, 25.0f);
  }
  float Visibility(bool hard) {
    static const float kHard[] = {0.0f, 1.0f, kNaN, 2.5f, -0.0f};
    if (hard && Chance(0.1f)) return OneOf(kHard);
    return Chance(0.5f) ? (Chance(0.7f) ? 1.0f : 0.0f) : Uniform();
  }
  float SelectionUniform() {
    static const float kEdge[] = {0.0f, 0x1.fffffep-1f};
    return Chance(0.03f) ? OneOf(kEdge) : Uniform();
  }
  float Target(bool hard) {  // p̂_j(Y_i)
    static const float kHard[] = {0.0f, -0.0f, -2.0f, kNaN, kInf, 1e30f, 1e-40f, 3e38f};
    if (hard && Chance(0.25f)) return OneOf(kHard);
    return Chance(0.1f) ? 0.0f : LogUniform(1e-3f, 1e2f);
  }
  float Mis(bool hard) {  // m_i(Y_i) given to GrisResample
    static const float kHard[] = {0.0f, -0.5f, kNaN, kInf, 1e30f, 2.0f, 1e-40f};
    return hard && Chance(0.25f) ? OneOf(kHard) : Uniform();
  }

 private:
  std::mt19937 rng_;
};

// A random batch of `count` combinations (row stride count + extra) with up to M inputs each.
Batch RandomBatch(Gen& g, size_t count, size_t extraStride, int M, float hardFraction = 0.5f) {
  Batch b;
  b.count = count;
  b.stride = count + extraStride;
  b.matrixSize = M;
  const size_t rows = std::max<size_t>(1, static_cast<size_t>(M) * b.stride);
  b.inputs.assign(std::max<size_t>(1, b.stride), 0);
  b.hasSample.assign(rows, 0);
  for (auto* v : {&b.W, &b.confidence, &b.visibility, &b.u, &b.mis, &b.canonicalTarget}) v->assign(rows, 0.0f);
  b.target.assign(rows * static_cast<size_t>(M), 0.0f);
  for (size_t k = 0; k < count; ++k) {
    const float r = g.Uniform();
    Regime regime = Regime::kClean;
    if (r < hardFraction) regime = Regime::kHard;
    else if (r < hardFraction + 0.05f) regime = Regime::kAllZeroW;
    else if (r < hardFraction + 0.15f) regime = Regime::kOverflow;
    else if (r < hardFraction + 0.25f) regime = Regime::kZeroRows;
    const bool hard = regime == Regime::kHard;
    // Mostly M inputs (the packet's largest count), else any count, rarely none.
    const int n = g.Chance(0.02f) ? 0 : (g.Chance(0.4f) ? M : 1 + static_cast<int>(g.Rng()() % M));
    b.inputs[k] = n;
    for (int i = 0; i < M; ++i) {
      const size_t e = b.At(i, k);
      b.hasSample[e] = g.Chance(hard ? 0.8f : 0.95f) ? 1 : 0;
      b.W[e] = regime == Regime::kAllZeroW ? 0.0f : g.Weight(hard);
      if (regime == Regime::kOverflow && g.Chance(0.5f)) b.W[e] = 1e30f;
      b.confidence[e] = g.Confidence(hard);
      b.visibility[e] = g.Visibility(hard);
      b.u[e] = g.SelectionUniform();
      b.mis[e] = g.Mis(hard);
      b.canonicalTarget[e] = g.Target(hard);
      if (regime == Regime::kOverflow && g.Chance(0.5f)) b.canonicalTarget[e] = 1e30f;
    }
    const int zeroRow = regime == Regime::kZeroRows ? static_cast<int>(g.Rng()() % M) : -1;
    for (int j = 0; j < M; ++j)
      for (int i = 0; i < M; ++i) {
        float t = g.Target(hard);
        if (regime == Regime::kOverflow && g.Chance(0.5f)) t = 1e30f;
        if (j == zeroRow || (regime == Regime::kZeroRows && i == 0 && g.Chance(0.3f))) t = 0.0f;
        b.target[b.TargetAt(j, i, k)] = t;
      }
  }
  return b;
}

// GrisCombine on combination k alone, recording the matrix entries it reads.
GrisResult Reference(MisFamily family, VisibilityCarry carry, Batch& b, size_t k) {
  GrisInput in[kMaxGrisInputs];
  float u[kMaxGrisInputs];
  const int n = b.inputs[k];
  for (int i = 0; i < n; ++i) {
    const size_t e = b.At(i, k);
    in[i] = GrisInput{b.hasSample[e] != 0, b.W[e], b.confidence[e], b.visibility[e]};
    u[i] = b.u[e];
  }
  const auto target = [&](int j, int i) {
    const size_t e = b.TargetAt(j, i, k);
    b.read[e] = 1;
    return b.target[e];
  };
  return GrisCombine(family, in, n, target, u, carry);
}

GrisResult ResampleReference(VisibilityCarry carry, const Batch& b, size_t k) {
  GrisInput in[kMaxGrisInputs];
  float u[kMaxGrisInputs], mis[kMaxGrisInputs], pc[kMaxGrisInputs];
  const int n = b.inputs[k];
  for (int i = 0; i < n; ++i) {
    const size_t e = b.At(i, k);
    in[i] = GrisInput{b.hasSample[e] != 0, b.W[e], b.confidence[e], b.visibility[e]};
    u[i] = b.u[e];
    mis[i] = b.mis[e];
    pc[i] = b.canonicalTarget[e];
  }
  return GrisResample(in, mis, pc, n, u, carry);
}

// Overwrites every target entry GrisCombine did not read for `family`; returns how many it overwrote.
size_t FillUnread(MisFamily family, VisibilityCarry carry, Batch& b, Unread unread, Gen& g) {
  if (unread == Unread::kAsDrawn) return 0;
  b.read.assign(b.target.size(), 0);
  for (size_t k = 0; k < b.count; ++k) Reference(family, carry, b, k);
  static const float kWild[] = {kNaN, -kNaN, kInf, -kInf, 1e30f, -5.0f, 7.0f, 1e-40f, 0.5f};
  size_t filled = 0;
  for (size_t e = 0; e < b.target.size(); ++e) {
    if (b.read[e]) continue;
    b.target[e] = unread == Unread::kZero ? 0.0f : unread == Unread::kNaN ? kNaN : g.OneOf(kWild);
    ++filled;
  }
  return filled;
}

// Output arrays with `pad` sentinel elements after the count, to catch writes past the batch.
struct Outputs {
  static constexpr int32_t kSentinelI = -12345;
  static constexpr float kSentinelF = -7.25f;
  size_t count;
  std::vector<int32_t> selected, guarded;
  std::vector<float> weightSum, W, confidence, visibility;
  explicit Outputs(size_t n, size_t pad = 3)
      : count(n), selected(n + pad, kSentinelI), guarded(n + pad, kSentinelI), weightSum(n + pad, kSentinelF),
        W(n + pad, kSentinelF), confidence(n + pad, kSentinelF), visibility(n + pad, kSentinelF) {}
  GrisBatchOutput View() {
    return {selected.data(), weightSum.data(), W.data(), confidence.data(), visibility.data(), guarded.data()};
  }
};

// What the batches must reproduce, and how often the interesting paths were taken.
struct Coverage {
  size_t combinations = 0, selected = 0, empty = 0, guarded = 0, nanOutputs = 0;
};

// Bitwise comparison of combination k's outputs with a reference result (its NaNs made canonical).
::testing::AssertionResult SameBits(const GrisResult& e, const Outputs& o, size_t k) {
  const float ef[4] = {Canonical(e.weightSum), Canonical(e.W), Canonical(e.confidence), Canonical(e.visibility)};
  const float of[4] = {o.weightSum[k], o.W[k], o.confidence[k], o.visibility[k]};
  static const char* kNames[4] = {"weightSum", "W", "confidence", "visibility"};
  if (e.selected != o.selected[k])
    return ::testing::AssertionFailure() << "combination " << k << " selected " << o.selected[k] << ", expected "
                                         << e.selected;
  if (e.guarded != o.guarded[k])
    return ::testing::AssertionFailure() << "combination " << k << " guarded " << o.guarded[k] << ", expected "
                                         << e.guarded;
  for (int f = 0; f < 4; ++f)
    if (Bits(ef[f]) != Bits(of[f]))
      return ::testing::AssertionFailure() << "combination " << k << " " << kNames[f] << " " << of[f] << " (0x"
                                           << std::hex << Bits(of[f]) << "), expected " << ef[f] << " (0x"
                                           << Bits(ef[f]) << ")";
  return ::testing::AssertionSuccess();
}

::testing::AssertionResult PaddingUntouched(const Outputs& o) {
  for (size_t k = o.count; k < o.selected.size(); ++k)
    if (o.selected[k] != Outputs::kSentinelI || o.guarded[k] != Outputs::kSentinelI ||
        Bits(o.weightSum[k]) != Bits(Outputs::kSentinelF) || Bits(o.W[k]) != Bits(Outputs::kSentinelF) ||
        Bits(o.confidence[k]) != Bits(Outputs::kSentinelF) || Bits(o.visibility[k]) != Bits(Outputs::kSentinelF))
      return ::testing::AssertionFailure() << "element " << k << " past the batch was written";
  return ::testing::AssertionSuccess();
}

// Runs the twin and every target's GrisCombineBatch on `b` and checks each combination against GrisCombine.
void CheckCombine(MisFamily family, VisibilityCarry carry, Batch& b, const std::string& what, Coverage* cov) {
  std::vector<GrisResult> expected(b.count);
  b.read.assign(b.target.size(), 0);
  for (size_t k = 0; k < b.count; ++k) expected[k] = Reference(family, carry, b, k);
  const GrisBatch view = b.View();
  Outputs twin(b.count);
  GrisCombineBatchScalar(family, carry, view, twin.View());
  for (size_t k = 0; k < b.count; ++k) ASSERT_TRUE(SameBits(expected[k], twin, k)) << what << " twin";
  ASSERT_TRUE(PaddingUntouched(twin)) << what << " twin";
  for (SimdTarget t : SupportedSimdTargets()) {
    ASSERT_TRUE(SetSimdTarget(t));
    Outputs o(b.count);
    GrisCombineBatch(family, carry, view, o.View());
    for (size_t k = 0; k < b.count; ++k) ASSERT_TRUE(SameBits(expected[k], o, k)) << what << " " << SimdTargetName(t);
    ASSERT_TRUE(PaddingUntouched(o)) << what << " " << SimdTargetName(t);
  }
  if (!cov) return;
  for (size_t k = 0; k < b.count; ++k) {
    const GrisResult& e = expected[k];
    ++cov->combinations;
    cov->selected += e.selected >= 0;
    cov->empty += e.selected < 0;
    cov->guarded += e.guarded > 0;
    cov->nanOutputs += std::isnan(e.W) || std::isnan(e.confidence) || std::isnan(e.visibility);
  }
}

void CheckResample(VisibilityCarry carry, const Batch& b, const std::string& what, Coverage* cov) {
  std::vector<GrisResult> expected(b.count);
  for (size_t k = 0; k < b.count; ++k) expected[k] = ResampleReference(carry, b, k);
  GrisBatch view = b.View();
  view.target = nullptr;  // GrisResampleBatch must not need the matrix
  Outputs twin(b.count);
  GrisResampleBatchScalar(carry, view, twin.View());
  for (size_t k = 0; k < b.count; ++k) ASSERT_TRUE(SameBits(expected[k], twin, k)) << what << " twin";
  for (SimdTarget t : SupportedSimdTargets()) {
    ASSERT_TRUE(SetSimdTarget(t));
    Outputs o(b.count);
    GrisResampleBatch(carry, view, o.View());
    for (size_t k = 0; k < b.count; ++k) ASSERT_TRUE(SameBits(expected[k], o, k)) << what << " " << SimdTargetName(t);
    ASSERT_TRUE(PaddingUntouched(o)) << what << " " << SimdTargetName(t);
  }
  if (!cov) return;
  for (size_t k = 0; k < b.count; ++k) {
    ++cov->combinations;
    cov->selected += expected[k].selected >= 0;
    cov->empty += expected[k].selected < 0;
    cov->guarded += expected[k].guarded > 0;
    cov->nanOutputs += std::isnan(expected[k].W) || std::isnan(expected[k].visibility);
  }
}

// Batch sizes around every vector width (4, 8, 16 lanes) and beyond.
constexpr size_t kSizes[] = {0, 1, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 33, 64, 65, 257};

void ExpectCovered(const Coverage& c, const std::string& what) {
  // The batches took every path: selections, empty results, guarded weights and NaN outputs.
  EXPECT_GT(c.selected, c.combinations / 3) << what;
  EXPECT_GT(c.empty, c.combinations / 50) << what;
  EXPECT_GT(c.guarded, c.combinations / 50) << what;
  EXPECT_GT(c.nanOutputs, 0u) << what;
}

TEST_F(GrisKernel, EveryFamilyMatchesGrisCombineBitForBitOnEveryTarget) {
  Gen g(20261201);
  for (MisFamily family : kFamilies)
    for (VisibilityCarry carry : kCarries) {
      Coverage cov;
      for (int trial = 0; trial < 12; ++trial) {
        const size_t count = kSizes[g.Rng()() % std::size(kSizes)] + (trial == 0 ? 500 : 0);
        const int M = trial % 3 == 0 ? kMaxGrisInputs : 1 + static_cast<int>(g.Rng()() % kMaxGrisInputs);
        Batch b = RandomBatch(g, count, trial % 2 ? g.Rng()() % 6 : 0, M);
        const std::string what = std::string(MisFamilyName(family)) + "/" + Name(carry) + " trial " + std::to_string(trial);
        CheckCombine(family, carry, b, what, &cov);
        if (HasFatalFailure()) return;
      }
      ExpectCovered(cov, std::string(MisFamilyName(family)) + "/" + Name(carry));
    }
}

TEST_F(GrisKernel, UnreadTargetEntriesNeverReachTheResult) {
  // GrisCombine reads only some entries (core/gris_kernel.h lists them); the kernel computes on every lane, so
  // any value in the others (zeros as a lazy caller leaves them, NaN, wild finite and infinite values) must
  // leave every output unchanged.
  Gen g(77);
  for (MisFamily family : kFamilies)
    for (VisibilityCarry carry : kCarries)
      for (Unread unread : {Unread::kZero, Unread::kNaN, Unread::kWild}) {
        size_t filled = 0, entries = 0;
        for (int trial = 0; trial < 4; ++trial) {
          Batch b = RandomBatch(g, 61 + 16 * static_cast<size_t>(trial), trial % 2, trial < 2 ? kMaxGrisInputs : 6);
          filled += FillUnread(family, carry, b, unread, g);
          entries += b.target.size();
          CheckCombine(family, carry, b,
                       std::string(MisFamilyName(family)) + "/" + Name(carry) + " unread " +
                           std::to_string(static_cast<int>(unread)) + " trial " + std::to_string(trial),
                       nullptr);
          if (HasFatalFailure()) return;
        }
        // Most of the matrix is unread (a single column for z, none but row 0 for uniform): the fill mattered.
        EXPECT_GT(filled, entries / 4) << MisFamilyName(family);
      }
}

TEST_F(GrisKernel, ResampleMatchesGrisResampleBitForBitOnEveryTarget) {
  Gen g(4242);
  for (VisibilityCarry carry : kCarries) {
    Coverage cov;
    for (int trial = 0; trial < 30; ++trial) {
      const size_t count = kSizes[g.Rng()() % std::size(kSizes)] + (trial == 0 ? 700 : 0);
      Batch b = RandomBatch(g, count, trial % 2 ? g.Rng()() % 6 : 0, trial % 2 ? kMaxGrisInputs : 6);
      // GrisResample never reads the weights of inputs without a sample.
      if (trial % 3 == 0)
        for (size_t e = 0; e < b.hasSample.size(); ++e)
          if (!b.hasSample[e]) b.mis[e] = b.canonicalTarget[e] = b.W[e] = kNaN;
      CheckResample(carry, b, std::string(Name(carry)) + " trial " + std::to_string(trial), &cov);
      if (HasFatalFailure()) return;
    }
    ExpectCovered(cov, Name(carry));
  }
}

TEST_F(GrisKernel, TailsAndEmptyBatchesWriteExactlyTheirCombinations) {
  Gen g(3);
  for (size_t lanes : {4u, 8u, 16u})
    for (size_t count : {size_t{0}, size_t{1}, lanes - 1, lanes, lanes + 1, size_t{64}})
      for (MisFamily family : {MisFamily::kZ, MisFamily::kPairwise}) {
        Batch b = RandomBatch(g, count, 0, 6);
        CheckCombine(family, VisibilityCarry::kWeighted, b,
                     std::string(MisFamilyName(family)) + " count " + std::to_string(count), nullptr);
        CheckResample(VisibilityCarry::kSelected, b, "resample count " + std::to_string(count), nullptr);
        if (HasFatalFailure()) return;
      }
}

TEST_F(GrisKernel, OverflowingWeightsAreDroppedAndCountedAsGrisCombineDoes) {
  // w_i = m_i p̂_c(Y_i) W_i overflows to +Inf for W = p̂_c = 1e30 (finite inputs): GrisResample drops and
  // counts it (DESIGN §10); the kernel must count the same inputs.
  Gen g(99);
  for (MisFamily family : kFamilies) {
    Batch b = RandomBatch(g, 100, 0, 6, 0.0f);
    for (size_t k = 0; k < b.count; ++k) {
      b.inputs[k] = 6;
      for (int i = 0; i < 6; ++i) {
        b.hasSample[b.At(i, k)] = 1;
        if (i % 2 == static_cast<int>(k % 2)) b.W[b.At(i, k)] = 1e30f;
        for (int j = 0; j < 6; ++j)
          if (j == 0 || (i + j) % 3 == 0) b.target[b.TargetAt(j, i, k)] = 1e30f;
      }
    }
    Coverage cov;
    CheckCombine(family, VisibilityCarry::kWeighted, b, MisFamilyName(family), &cov);
    // Uniform weights c_i / Σ c ≤ 1 keep some products finite; every family guards some of them.
    EXPECT_GT(cov.guarded, b.count / 4) << MisFamilyName(family);
  }
}

TEST_F(GrisKernel, AllZeroWeightsSelectNothing) {
  Gen g(5);
  Batch b = RandomBatch(g, 37, 0, 6, 0.0f);
  for (float& w : b.W) w = 0.0f;
  for (MisFamily family : kFamilies)
    for (VisibilityCarry carry : kCarries) {
      CheckCombine(family, carry, b, MisFamilyName(family), nullptr);
      for (SimdTarget t : SupportedSimdTargets()) {
        ASSERT_TRUE(SetSimdTarget(t));
        Outputs o(b.count);
        GrisCombineBatch(family, carry, b.View(), o.View());
        for (size_t k = 0; k < b.count; ++k) {
          EXPECT_EQ(o.selected[k], -1);
          EXPECT_EQ(Bits(o.W[k]), 0u);
          EXPECT_EQ(Bits(o.weightSum[k]), 0u);
          EXPECT_EQ(Bits(o.visibility[k]), 0u);
          EXPECT_EQ(o.guarded[k], 0);
        }
      }
    }
}

}  // namespace gris_kernel_test
}  // namespace restir
