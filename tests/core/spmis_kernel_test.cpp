// The stochastic pairwise weights kernel (core/spmis_kernel.h): on every SIMD target this machine supports, and
// in the scalar twin, every combination of a batch gets the weights and canonical targets the spatial pass's
// loop of core/spmis.h functions gives it alone (seed 004 Eq. 15-19), bit for bit (DESIGN §3; NaN outputs are
// canonical), on random batches full of hard cases: zero, negative, NaN and infinite targets, confidences, c̄,
// draw counts, multiplicities and probabilities; inputs without samples; input counts 0..16 and distinct draw
// counts 0..15 mixed within a packet; batch sizes around the vector widths; and every value the loop does not
// read filled with garbage.
#include "core/spmis_kernel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <memory>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include "core/gris.h"
#include "core/gris_kernel.h"
#include "core/simd.h"
#include "core/spmis.h"

#include "core/kernel_test_support.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace spmis_kernel_test {

using test::Bits;
using test::Canonical;
using test::kInf;
using test::kNaN;

class StochasticPairwiseKernel : public test::SimdTargetTest {};

// The float arrays of a batch, for recording which entries the reference reads.
enum Array {
  kConfidence,
  kCBar,
  kDrawCount,
  kCanonicalDrawCount,
  kMultiplicity,
  kProbability,
  kCanonicalTargetIn,
  kOwnTarget,
  kDrawnMultiplicity,
  kDrawnProbability,
  kDrawnConfidence,
  kDrawnTarget,
  kArrays
};

struct Batch {
  GrisBatchArrays g;            // count, stride, matrixSize, inputs, hasSample, confidence
  StochasticPairwiseArrays sp;  // the rest
  std::vector<uint8_t> read[kArrays];
  std::vector<uint8_t> distinctRead;  // per combination: the reference read its distinct-draw count

  std::vector<float>& Of(Array a) {
    switch (a) {
      case kConfidence: return g.confidence;
      case kCBar: return sp.cBar;
      case kDrawCount: return sp.drawCount;
      case kCanonicalDrawCount: return sp.canonicalDrawCount;
      case kMultiplicity: return sp.multiplicity;
      case kProbability: return sp.probability;
      case kCanonicalTargetIn: return sp.canonicalTarget;
      case kOwnTarget: return sp.ownTarget;
      case kDrawnMultiplicity: return sp.drawnMultiplicity;
      case kDrawnProbability: return sp.drawnProbability;
      case kDrawnConfidence: return sp.drawnConfidence;
      case kDrawnTarget: return sp.drawnTarget;
      case kArrays: break;
    }
    return g.confidence;
  }
  StochasticPairwiseBatch View() const { return sp.View(g); }
  size_t At(int t, size_t k) const { return g.At(t, k); }
};

class Gen {
 public:
  explicit Gen(uint32_t seed) : rng_(seed) {}
  std::mt19937& Rng() { return rng_; }
  float Uniform() { return std::uniform_real_distribution<float>(0.0f, 1.0f)(rng_); }
  bool Chance(float p) { return Uniform() < p; }
  int Int(int lo, int hi) { return lo + static_cast<int>(rng_() % static_cast<uint32_t>(hi - lo + 1)); }
  template <size_t n>
  float OneOf(const float (&v)[n]) { return v[rng_() % n]; }
  float LogUniform(float lo, float hi) { return lo * std::pow(hi / lo, Uniform()); }

  float Confidence(bool hard, float scale) {  // c_t, c_j: capped history times N/M
    static const float kHard[] = {0.0f, 0.0f, -0.0f, 1e30f, kNaN, kInf, -1.0f, 1e-40f, 3e38f};
    if (hard && Chance(0.2f)) return OneOf(kHard);
    return static_cast<float>(Int(1, 20)) * scale;
  }
  float CBar(bool hard, float scale) {
    static const float kHard[] = {0.0f, -0.0f, kNaN, kInf, -3.0f, 1e30f, 1e-40f};
    if (hard && Chance(0.15f)) return OneOf(kHard);
    return static_cast<float>(Int(1, 400)) * scale;
  }
  float Count(bool hard, int lo, int hi) {  // N, N_c, M, K
    static const float kHard[] = {0.0f, -0.0f, kNaN, kInf, -1.0f, 1e-40f, 1e30f};
    if (hard && Chance(0.1f)) return OneOf(kHard);
    return static_cast<float>(Int(lo, hi));
  }
  float Probability(bool hard) {  // P(t)
    static const float kHard[] = {0.0f, -0.0f, kNaN, kInf, -0.25f, 1e-40f, 1.0f};
    if (hard && Chance(0.15f)) return OneOf(kHard);
    return LogUniform(1e-3f, 1.0f);
  }
  float Target(bool hard) {  // p̂_j(Y_i)
    static const float kHard[] = {0.0f, -0.0f, -2.0f, kNaN, kInf, 1e30f, 1e-40f, 3e38f, -kInf};
    if (hard && Chance(0.25f)) return OneOf(kHard);
    return Chance(0.15f) ? 0.0f : LogUniform(1e-3f, 1e2f);
  }

 private:
  std::mt19937 rng_;
};

// A random batch of `count` combinations (row stride count + extra) with up to `rows` inputs and draws.
Batch RandomBatch(Gen& g, size_t count, size_t extraStride, int rows = kMaxGrisInputs,
                  int drawRows = kMaxCanonicalDraws, float hardFraction = 0.5f) {
  Batch b;
  GrisBatchArrays& a = b.g;
  a.count = count;
  a.stride = count + extraStride;
  a.matrixSize = rows;
  const size_t rowElements = static_cast<size_t>(rows) * a.stride;
  a.inputs.assign(a.stride, 0);
  a.hasSample.assign(rowElements, 0);
  a.confidence.assign(rowElements, 0.0f);
  a.mis.assign(rowElements, 0.0f);
  a.canonicalTarget.assign(rowElements, 0.0f);
  b.sp.Resize(a, drawRows);
  StochasticPairwiseArrays& s = b.sp;
  for (size_t k = 0; k < count; ++k) {
    const bool hard = g.Chance(hardFraction);
    // Mostly a full packet's worth of inputs, else any count, rarely none; likewise for the distinct draws.
    a.inputs[k] = g.Chance(0.02f) ? 0 : (g.Chance(0.3f) ? rows : g.Int(1, rows));
    s.distinct[k] = drawRows == 0 ? 0 : (g.Chance(0.3f) ? drawRows : g.Int(0, drawRows));
    const float n = g.Count(false, 1, 15);
    const float m = static_cast<float>(g.Int(1, 64));
    // Confidence scaling (seed 004 §4.3) in most combinations: c_t and c̄ times N/M, inexact fractions.
    const float scale = g.Chance(0.7f) ? n / m : 1.0f;
    s.cBar[k] = g.CBar(hard, scale);
    s.drawCount[k] = hard && g.Chance(0.1f) ? g.Count(true, 1, 15) : n;
    s.canonicalDrawCount[k] = g.Count(hard, 1, 15);
    // A fifth of the lanes: no canonical confidence or zero canonical targets, so pairs fall to the defensive
    // branch (c̄ p̂_j(Y_c) + c_c p̂_c(Y_c) not > 0).
    const bool defensive = g.Chance(0.2f);
    for (int t = 0; t < rows; ++t) {
      const size_t e = b.At(t, k);
      a.hasSample[e] = g.Chance(hard ? 0.8f : 0.95f) ? 1 : 0;
      a.confidence[e] = t == 0 ? g.Confidence(hard, 1.0f) : g.Confidence(hard, scale);
      s.multiplicity[e] = g.Count(hard, 1, 15);
      s.probability[e] = g.Probability(hard);
      s.canonicalTarget[e] = g.Target(hard);
      s.ownTarget[e] = g.Target(hard);
    }
    if (defensive) a.confidence[b.At(0, k)] = g.Chance(0.5f) ? 0.0f : -0.0f;
    for (int d = 0; d < drawRows; ++d) {
      const size_t e = s.DrawAt(d, k);
      s.drawnMultiplicity[e] = g.Count(hard, 1, 5);
      // P_c(j): uniform 1/M (as the pass computes it) or ∝ c_j (any fraction of the cell).
      s.drawnProbability[e] = g.Chance(0.5f) ? 1.0f / m : g.Probability(hard);
      s.drawnConfidence[e] = g.Confidence(hard, scale);
      s.drawnTarget[e] = defensive && g.Chance(0.6f) ? 0.0f : g.Target(hard);
    }
  }
  for (auto& r : b.read) r.clear();
  b.distinctRead.clear();
  return b;
}

// How often the interesting paths were taken.
struct Coverage {
  size_t combinations = 0, canonicalWithDraws = 0, defensive = 0, nonCanonical = 0, probabilityGuard = 0,
         positive = 0, nanOutputs = 0;
};

// The pipeline's block for combination k alone (sim/estimator/pipeline.cpp "Stochastic pairwise (seed 004 Eq. 15-19)"),
// recording the entries it reads.
void Reference(Batch& b, size_t k, float* mis, float* pc, Coverage* cov) {
  const auto F = [&](Array a, size_t e) {
    std::vector<float>& v = b.Of(a);
    if (b.read[a].size() != v.size()) b.read[a].assign(v.size(), 0);
    b.read[a][e] = 1;
    return v[e];
  };
  const int n = b.g.inputs[k];
  const auto has = [&](int t) { return b.g.hasSample[b.At(t, k)] != 0; };
  for (int t = 0; t < n; ++t) {
    mis[t] = 0.0f;
    pc[t] = has(t) ? F(kCanonicalTargetIn, b.At(t, k)) : 0.0f;
  }
  if (n > 0 && has(0) && pc[0] > 0.0f) {
    if (b.distinctRead.size() != b.g.stride) b.distinctRead.assign(b.g.stride, 0);
    b.distinctRead[k] = 1;
    const float cBar = F(kCBar, k), cc = F(kConfidence, b.At(0, k));
    mis[0] = MisPairwiseCanonicalBase(cBar, cc);
    for (int d = 0; d < b.sp.distinct[k]; ++d) {
      const size_t e = b.sp.DrawAt(d, k);
      const float tj = F(kDrawnTarget, e);
      if (cov && cBar + cc > 0.0f && !(cBar * tj + cc * pc[0] > 0.0f)) ++cov->defensive;
      mis[0] += StochasticPairwiseCanonicalTerm(F(kDrawnMultiplicity, e), F(kCanonicalDrawCount, k),
                                                F(kDrawnProbability, e), F(kDrawnConfidence, e), cBar, cc,
                                                tj, pc[0]);
    }
    if (cov) cov->canonicalWithDraws += b.sp.distinct[k] > 0;
  }
  for (int t = 1; t < n; ++t)
    if (has(t) && pc[t] > 0.0f) {
      const size_t e = b.At(t, k);
      const float p = F(kProbability, e);
      mis[t] = StochasticPairwiseNonCanonical(F(kMultiplicity, e), F(kDrawCount, k), p, F(kConfidence, e),
                                              F(kCBar, k), F(kConfidence, b.At(0, k)), F(kOwnTarget, e), pc[t]);
      if (cov) cov->nonCanonical++, cov->probabilityGuard += !(p > 0.0f);
    }
  if (!cov) return;
  ++cov->combinations;
  for (int t = 0; t < n; ++t) {
    cov->positive += mis[t] > 0.0f;
    cov->nanOutputs += std::isnan(mis[t]) || std::isnan(pc[t]);
  }
}

struct Expected {
  std::vector<float> mis, pc;  // [t * stride + k], canonical NaNs
};

Expected ReferenceBatch(Batch& b, Coverage* cov) {
  Expected x;
  x.mis.assign(b.g.mis.size(), 0.0f);
  x.pc.assign(b.g.mis.size(), 0.0f);
  for (size_t k = 0; k < b.g.count; ++k) {
    float mis[kMaxGrisInputs], pc[kMaxGrisInputs];
    Reference(b, k, mis, pc, cov);
    for (int t = 0; t < b.g.inputs[k]; ++t) {
      x.mis[b.At(t, k)] = Canonical(mis[t]);
      x.pc[b.At(t, k)] = Canonical(pc[t]);
    }
  }
  return x;
}

// Output rows with sentinels everywhere and `pad` elements past the last row, to catch stray writes.
struct Outputs {
  static constexpr float kSentinel = -7.25f;
  std::vector<float> mis, pc;
  Outputs(const Batch& b, size_t pad = 5)
      : mis(b.g.mis.size() + pad, kSentinel), pc(b.g.mis.size() + pad, kSentinel) {}
  StochasticPairwiseOutput View() { return {mis.data(), pc.data()}; }
};

// Combination k's entries t < inputs[k] equal the reference bit for bit; every other element kept `before`.
::testing::AssertionResult SameBits(const Batch& b, const Expected& x, const std::vector<float>& mis,
                                    const std::vector<float>& pc, const std::vector<float>& misBefore,
                                    const std::vector<float>& pcBefore) {
  std::vector<uint8_t> owned(mis.size(), 0);
  for (size_t k = 0; k < b.g.count; ++k)
    for (int t = 0; t < b.g.inputs[k]; ++t) {
      const size_t e = b.At(t, k);
      owned[e] = 1;
      if (Bits(mis[e]) != Bits(x.mis[e]) || Bits(pc[e]) != Bits(x.pc[e]))
        return ::testing::AssertionFailure()
               << "combination " << k << " (inputs " << b.g.inputs[k] << ", distinct " << b.sp.distinct[k]
               << ") input " << t << ": mis " << mis[e] << " (0x" << std::hex << Bits(mis[e]) << "), expected "
               << x.mis[e] << " (0x" << Bits(x.mis[e]) << "); pc " << pc[e] << " (0x" << Bits(pc[e])
               << "), expected " << x.pc[e] << " (0x" << Bits(x.pc[e]) << ")";
    }
  for (size_t e = 0; e < mis.size(); ++e)
    if (!owned[e] && (Bits(mis[e]) != Bits(misBefore[e]) || Bits(pc[e]) != Bits(pcBefore[e])))
      return ::testing::AssertionFailure() << "element " << e << " outside the combinations' inputs was written";
  return ::testing::AssertionSuccess();
}

// Runs the twin and every target on `b` and checks each against the reference.
void Check(Batch& b, const std::string& what, Coverage* cov) {
  const Expected x = ReferenceBatch(b, cov);
  const StochasticPairwiseBatch view = b.View();
  {
    Outputs o(b);
    const Outputs before = o;
    StochasticPairwiseWeightsScalar(view, o.View());
    ASSERT_TRUE(SameBits(b, x, o.mis, o.pc, before.mis, before.pc)) << what << " twin";
  }
  for (SimdTarget t : SupportedSimdTargets()) {
    ASSERT_TRUE(SetSimdTarget(t));
    Outputs o(b);
    const Outputs before = o;
    StochasticPairwiseWeights(view, o.View());
    ASSERT_TRUE(SameBits(b, x, o.mis, o.pc, before.mis, before.pc)) << what << " " << SimdTargetName(t);
  }
}

// Batch sizes around every vector width (4, 8, 16 lanes) and beyond.
constexpr size_t kSizes[] = {0, 1, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 33, 63, 64, 65, 100};

TEST_F(StochasticPairwiseKernel, WeightsMatchTheScalarFunctionsBitForBitOnEveryTarget) {
  Gen g(20261204);
  Coverage cov;
  for (int trial = 0; trial < 3000; ++trial) {
    const size_t count = kSizes[g.Rng()() % std::size(kSizes)];
    // Mostly the pipeline's shapes (16 input rows, 15 draw rows); else narrower arrays.
    const int rows = trial % 4 == 0 ? 1 + static_cast<int>(g.Rng()() % kMaxGrisInputs) : kMaxGrisInputs;
    const int drawRows = trial % 4 == 1 ? static_cast<int>(g.Rng()() % (kMaxCanonicalDraws + 1)) : kMaxCanonicalDraws;
    Batch b = RandomBatch(g, count, trial % 2 ? g.Rng()() % 6 : 0, rows, drawRows, trial % 3 == 0 ? 0.1f : 0.5f);
    Check(b, "trial " + std::to_string(trial), &cov);
    if (HasFatalFailure()) return;
  }
  // The batches took every path: weighted canonical draws, the defensive branch, the P(t) > 0 guard, NaN outputs.
  EXPECT_GT(cov.combinations, 50000u);
  EXPECT_GT(cov.canonicalWithDraws, cov.combinations / 4);
  EXPECT_GT(cov.defensive, cov.combinations / 20);
  EXPECT_GT(cov.nonCanonical, cov.combinations);
  EXPECT_GT(cov.probabilityGuard, cov.combinations / 50);
  EXPECT_GT(cov.positive, cov.combinations);
  EXPECT_GT(cov.nanOutputs, cov.combinations / 50);
}

TEST_F(StochasticPairwiseKernel, UnreadEntriesNeverReachTheResult) {
  // The loop reads only some values (core/spmis_kernel.h lists them); the kernel computes on every lane, so any
  // value in the others (entries past a lane's input and draw counts, inputs without a weight) must leave every
  // output unchanged.
  Gen g(77);
  static const float kWild[] = {kNaN, -kNaN, kInf, -kInf, 1e30f, -5.0f, 7.0f, 1e-40f, 0.5f, 0.0f};
  size_t filled = 0, entries = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const size_t count = kSizes[g.Rng()() % std::size(kSizes)] + 1;
    Batch b = RandomBatch(g, count, trial % 2, trial % 3 ? kMaxGrisInputs : 7, trial % 5 ? kMaxCanonicalDraws : 4);
    const Expected clean = ReferenceBatch(b, nullptr);
    for (int a = 0; a < kArrays; ++a) {
      std::vector<float>& v = b.Of(static_cast<Array>(a));
      b.read[a].resize(v.size(), 0);
      for (size_t e = 0; e < v.size(); ++e) {
        if (b.read[a][e]) continue;
        v[e] = g.OneOf(kWild);
        ++filled;
      }
      entries += v.size();
    }
    // Sample flags and draw counts past a lane's counts, and lanes past the batch.
    for (size_t k = 0; k < b.g.stride; ++k) {
      const int n = k < count ? b.g.inputs[k] : 0;
      for (int t = n; t < b.g.matrixSize; ++t) b.g.hasSample[b.At(t, k)] = static_cast<uint8_t>(g.Rng()());
      if (k >= count) b.g.inputs[k] = g.Int(-3, 40);
      if (k >= count || !(k < b.distinctRead.size() && b.distinctRead[k])) b.sp.distinct[k] = g.Int(-3, 40);
    }
    const Expected dirty = ReferenceBatch(b, nullptr);
    ASSERT_EQ(clean.mis.size(), dirty.mis.size());
    for (size_t e = 0; e < clean.mis.size(); ++e)
      ASSERT_EQ(Bits(clean.mis[e]), Bits(dirty.mis[e])) << "the reference read a garbage entry";
    Check(b, "unread trial " + std::to_string(trial), nullptr);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(filled, entries / 3);
}

TEST_F(StochasticPairwiseKernel, TailsReadAndWriteExactlyTheirCombinations) {
  // Every array ends where an inaccessible page begins (stride = count): a packet load or store past the last
  // combination faults.
  Gen g(3);
  for (size_t lanes : {4u, 8u, 16u})
    for (size_t count : {size_t{0}, size_t{1}, lanes - 1, lanes, lanes + 1, size_t{64}}) {
      Batch b = RandomBatch(g, count, 0);
      const Expected x = ReferenceBatch(b, nullptr);
      const auto guard = [](const auto& v) {
        using T = typename std::decay_t<decltype(v)>::value_type;
        auto a = std::make_unique<test::GuardedArray<T>>(v.size());
        std::copy(v.begin(), v.end(), a->data());
        return a;
      };
      auto inputs = guard(b.g.inputs), distinct = guard(b.sp.distinct);
      auto hasSample = guard(b.g.hasSample);
      std::unique_ptr<test::GuardedArray<float>> f[kArrays];
      for (int a = 0; a < kArrays; ++a) f[a] = guard(b.Of(static_cast<Array>(a)));
      StochasticPairwiseBatch view = b.View();
      view.inputs = inputs->data();
      view.distinct = distinct->data();
      view.hasSample = hasSample->data();
      view.confidence = f[kConfidence]->data();
      view.cBar = f[kCBar]->data();
      view.drawCount = f[kDrawCount]->data();
      view.canonicalDrawCount = f[kCanonicalDrawCount]->data();
      view.multiplicity = f[kMultiplicity]->data();
      view.probability = f[kProbability]->data();
      view.canonicalTarget = f[kCanonicalTargetIn]->data();
      view.ownTarget = f[kOwnTarget]->data();
      view.drawnMultiplicity = f[kDrawnMultiplicity]->data();
      view.drawnProbability = f[kDrawnProbability]->data();
      view.drawnConfidence = f[kDrawnConfidence]->data();
      view.drawnTarget = f[kDrawnTarget]->data();
      const std::vector<float> sentinel(b.g.mis.size(), Outputs::kSentinel);
      for (SimdTarget t : SupportedSimdTargets()) {
        ASSERT_TRUE(SetSimdTarget(t));
        test::GuardedArray<float> mis(sentinel.size()), pc(sentinel.size());
        std::copy(sentinel.begin(), sentinel.end(), mis.data());
        std::copy(sentinel.begin(), sentinel.end(), pc.data());
        StochasticPairwiseWeights(view, {mis.data(), pc.data()});
        const std::vector<float> misOut(mis.data(), mis.data() + sentinel.size());
        const std::vector<float> pcOut(pc.data(), pc.data() + sentinel.size());
        ASSERT_TRUE(SameBits(b, x, misOut, pcOut, sentinel, sentinel))
            << "count " << count << " " << SimdTargetName(t);
      }
    }
}

TEST_F(StochasticPairwiseKernel, CanonicalTargetsMayBeComputedInPlace) {
  // The output canonical targets may overwrite the input p̂_c(Y_t) rows (a caller filling
  // GrisBatchArrays::canonicalTarget with target(0, t) directly).
  Gen g(11);
  for (int trial = 0; trial < 40; ++trial) {
    Batch b = RandomBatch(g, kSizes[g.Rng()() % std::size(kSizes)], trial % 3);
    const Expected x = ReferenceBatch(b, nullptr);
    const Outputs sentinels(b, 0);
    for (SimdTarget t : SupportedSimdTargets()) {
      ASSERT_TRUE(SetSimdTarget(t));
      std::vector<float> mis = sentinels.mis, pc = b.sp.canonicalTarget;
      StochasticPairwiseBatch view = b.View();
      view.canonicalTarget = pc.data();
      StochasticPairwiseWeights(view, {mis.data(), pc.data()});
      ASSERT_TRUE(SameBits(b, x, mis, pc, sentinels.mis, b.sp.canonicalTarget))
          << "trial " << trial << " " << SimdTargetName(t);
    }
  }
}

TEST_F(StochasticPairwiseKernel, FeedsGrisResampleBatchWithoutCopying) {
  // The pipeline's use: weights written into the GrisBatchArrays rows GrisResampleBatch reads give what
  // GrisResample gives with the loop's weights (whose NaN payloads the canonical NaNs replace: GrisResample only
  // tests them for finiteness).
  Gen g(5);
  for (int trial = 0; trial < 60; ++trial) {
    Batch b = RandomBatch(g, 64, 0);
    GrisBatchArrays& a = b.g;
    std::uniform_real_distribution<float> uni(0.0f, 1.0f);
    const size_t rowElements = a.hasSample.size();
    a.W.resize(rowElements);
    a.visibility.resize(rowElements);
    a.u.resize(rowElements);
    for (size_t e = 0; e < rowElements; ++e)
      a.W[e] = uni(g.Rng()) * 2.0f, a.visibility[e] = uni(g.Rng()), a.u[e] = uni(g.Rng());
    std::vector<GrisResult> expected(a.count);
    for (size_t k = 0; k < a.count; ++k) {
      float mis[kMaxGrisInputs], pc[kMaxGrisInputs], u[kMaxGrisInputs];
      GrisInput in[kMaxGrisInputs];
      Reference(b, k, mis, pc, nullptr);
      for (int t = 0; t < a.inputs[k]; ++t) {
        const size_t e = a.At(t, k);
        in[t] = GrisInput{a.hasSample[e] != 0, a.W[e], a.confidence[e], a.visibility[e]};
        u[t] = a.u[e];
      }
      expected[k] = GrisResample(in, mis, pc, a.inputs[k], u, VisibilityCarry::kWeighted);
    }
    for (SimdTarget t : SupportedSimdTargets()) {
      ASSERT_TRUE(SetSimdTarget(t));
      StochasticPairwiseWeights(b.View(), StochasticPairwiseOutputInto(a));
      int32_t selected[64], guarded[64];
      float weightSum[64], W[64], confidence[64], visibility[64];
      GrisResampleBatch(VisibilityCarry::kWeighted, a.View(),
                        GrisBatchOutput{selected, weightSum, W, confidence, visibility, guarded});
      for (size_t k = 0; k < a.count; ++k) {
        const GrisResult& e = expected[k];
        ASSERT_EQ(selected[k], e.selected) << k << " " << SimdTargetName(t);
        ASSERT_EQ(guarded[k], e.guarded) << k << " " << SimdTargetName(t);
        ASSERT_EQ(Bits(W[k]), Bits(Canonical(e.W))) << k << " " << SimdTargetName(t);
        ASSERT_EQ(Bits(weightSum[k]), Bits(Canonical(e.weightSum))) << k << " " << SimdTargetName(t);
        ASSERT_EQ(Bits(visibility[k]), Bits(Canonical(e.visibility))) << k << " " << SimdTargetName(t);
        ASSERT_EQ(Bits(confidence[k]), Bits(Canonical(e.confidence))) << k << " " << SimdTargetName(t);
      }
    }
  }
}

}  // namespace spmis_kernel_test
}  // namespace restir
