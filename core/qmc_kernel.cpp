// Highway kernel, scalar twin and dispatcher of the randomised-QMC point kernel (core/qmc_kernel.h). The
// per-target part is compiled once per Highway target (foreach_target.h); the rest once (HWY_ONCE).
//
// Bit-exactness (DESIGN §3): integer lanes throughout: shift + k alpha modulo 2^32, its top 24 bits converted
// exactly and scaled by 2^-24 as BitsToUnitFloat; the words are core/rng.h RandomWords4 in integer lanes
// (core/rng-inl.h).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/qmc_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "hwy/highway.h"

#include "core/qmc_kernel.h"
#include "core/rng-inl.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/simd.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void QmcKernel(const uint32_t* shifts, size_t copies, size_t count, uint32_t alpha, float* out) {
  const hn::ScalableTag<uint32_t> du;
  const hn::RebindToSigned<decltype(du)> di;
  const hn::RebindToFloat<decltype(du)> df;
  const size_t N = hn::Lanes(du);
  const auto toFloat = [&](auto word) {  // BitsToUnitFloat: the top 24 bits, exact as int32 and as float
    return hn::Mul(hn::ConvertTo(df, hn::BitCast(di, hn::ShiftRight<8>(word))), hn::Set(df, 0x1.0p-24f));
  };
  if (copies % N == 0) {
    // A packet is N copies' point k: their shifts plus k alpha (modulo 2^32, as the twin's k * alpha).
    for (size_t r = 0; r < copies; r += N) {
      const auto shift = hn::LoadU(du, shifts + r);
      auto offset = hn::Zero(du);
      for (size_t k = 0; k < count; ++k, offset = hn::Add(offset, hn::Set(du, alpha)))
        hn::StoreU(toFloat(hn::Add(shift, offset)), df, out + k * copies + r);
    }
    return;
  }
  if (copies == 1) {
    // A packet is N consecutive points of the one copy.
    auto word = hn::Add(hn::Set(du, shifts[0]), hn::Mul(hn::Iota(du, 0u), hn::Set(du, alpha)));
    const auto step = hn::Set(du, static_cast<uint32_t>(N) * alpha);
    size_t k = 0;
    for (; k + N <= count; k += N, word = hn::Add(word, step)) hn::StoreU(toFloat(word), df, out + k);
    for (; k < count; ++k) out[k] = RobertsCoordinate(shifts[0], static_cast<uint32_t>(k), alpha);
    return;
  }
  for (size_t k = 0; k < count; ++k)
    for (size_t r = 0; r < copies; ++r)
      out[k * copies + r] = RobertsCoordinate(shifts[r], static_cast<uint32_t>(k), alpha);
}

void PixelWords4Kernel(const RngKey& key, const uint32_t* pixels, size_t count, uint32_t first, size_t groups,
                       uint32_t* out) {
  const hn::ScalableTag<uint32_t> du;
  using VU = hn::Vec<decltype(du)>;
  const size_t N = hn::Lanes(du);
  for (size_t p = 0; p < count; p += N) {
    HWY_ALIGN uint32_t lanes[hn::MaxLanes(du)] = {};
    for (size_t l = 0; l < N && p + l < count; ++l) lanes[l] = pixels[p + l];
    const auto pixel = hn::Load(du, lanes);
    for (size_t g = 0; g < groups; ++g) {
      VU words[4];
      RandomWords4V(du, key, pixel, first + static_cast<uint32_t>(g), words);
      for (size_t i = 0; i < 4; ++i) {
        uint32_t* o = out + (4 * g + i) * count + p;
        if (p + N <= count) {
          hn::StoreU(words[i], du, o);
        } else {
          hn::Store(words[i], du, lanes);
          for (size_t l = 0; p + l < count; ++l) o[l] = lanes[l];
        }
      }
    }
  }
}

const char* QmcKernelTargetName() {
  return hwy::TargetName(HWY_TARGET);
}

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#if HWY_ONCE

namespace restir {

HWY_EXPORT(QmcKernel);
HWY_EXPORT(QmcKernelTargetName);
HWY_EXPORT(PixelWords4Kernel);

void PixelRandomWords4Scalar(const RngKey& key, const uint32_t* pixels, size_t count, uint32_t first, size_t groups,
                             uint32_t* out) {
  for (size_t g = 0; g < groups; ++g)
    for (size_t p = 0; p < count; ++p) {
      uint32_t words[4];
      RandomWords4(RngKey{key.seed, key.frame, pixels[p], key.pass}, first + static_cast<uint32_t>(g), words);
      for (size_t i = 0; i < 4; ++i) out[(4 * g + i) * count + p] = words[i];
    }
}

void PixelRandomWords4(const RngKey& key, const uint32_t* pixels, size_t count, uint32_t first, size_t groups,
                       uint32_t* out) {
  if (UseScalarTwins()) return PixelRandomWords4Scalar(key, pixels, count, first, groups, out);
  HWY_DYNAMIC_DISPATCH(PixelWords4Kernel)(key, pixels, count, first, groups, out);
}

void RobertsCoordinatesScalar(const uint32_t* shifts, size_t copies, size_t count, uint32_t alpha, float* out) {
  for (size_t k = 0; k < count; ++k)
    for (size_t r = 0; r < copies; ++r)
      out[k * copies + r] = RobertsCoordinate(shifts[r], static_cast<uint32_t>(k), alpha);
}

void RobertsCoordinates(const uint32_t* shifts, size_t copies, size_t count, uint32_t alpha, float* out) {
  if (UseScalarTwins()) return RobertsCoordinatesScalar(shifts, copies, count, alpha, out);
  HWY_DYNAMIC_DISPATCH(QmcKernel)(shifts, copies, count, alpha, out);
}

const char* QmcKernelDispatchedTargetName() {
  if (UseScalarTwins()) return "scalar";
  return HWY_DYNAMIC_DISPATCH(QmcKernelTargetName)();
}

}  // namespace restir

#endif  // HWY_ONCE
