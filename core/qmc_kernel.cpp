// Highway kernel, scalar twin and dispatcher of the randomised-QMC point kernel (core/qmc_kernel.h). The
// per-target part is compiled once per Highway target (foreach_target.h); the rest once (HWY_ONCE).
//
// Bit-exactness (DESIGN §3): per lane, v = shift + k alpha in double (k exact), floor(v) in place of the
// twin's truncation through int64 (the same for v >= 0), v - floor(v) exact, rounded to float as static_cast
// does, then std::min(x, 0x1.fffffep-1f) as its select. No MulAdd. The uniforms: core/rng.h RandomBits in
// integer lanes (core/rng-inl.h), the top 24 bits converted exactly and scaled by 2^-24 as BitsToUnitFloat.
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

void QmcKernel(const float* shifts, size_t copies, size_t count, double alpha, float* out) {
  const hn::ScalableTag<double> dd;
  const hn::Rebind<float, decltype(dd)> df;
  const size_t N = hn::Lanes(dd);
  const auto alphaV = hn::Set(dd, alpha);
  const auto below1 = hn::Set(df, 0x1.fffffep-1f);
  for (size_t r = 0; r < copies; ++r) {
    const double shift = shifts[r];
    const auto shiftV = hn::Set(dd, shift);
    float* o = out + r * count;
    size_t k = 0;
    for (; k + N <= count; k += N) {
      const auto v = hn::Add(shiftV, hn::Mul(hn::Iota(dd, static_cast<double>(k)), alphaV));
      const auto f = hn::DemoteTo(df, hn::Sub(v, hn::Floor(v)));
      hn::StoreU(hn::IfThenElse(hn::Lt(below1, f), below1, f), df, o + k);
    }
    for (; k < count; ++k) o[k] = RobertsCoordinate(shift, static_cast<int>(k), alpha);
  }
}

void UniformKernel(const RngKey& key, uint32_t first, uint32_t stride, size_t count, float* out, size_t rows,
                   uint32_t rowStride) {
  const hn::ScalableTag<uint32_t> du;
  const hn::RebindToSigned<decltype(du)> di;
  const hn::RebindToFloat<decltype(du)> df;
  const size_t N = hn::Lanes(du);
  const auto strideV = hn::Set(du, stride);
  for (size_t r = 0; r < rows; ++r) {
    const uint32_t rowFirst = first + static_cast<uint32_t>(r) * rowStride;
    float* o = out + r * count;
    size_t k = 0;
    for (; k + N <= count; k += N) {
      const auto dimension =
          hn::Add(hn::Set(du, rowFirst), hn::Mul(hn::Iota(du, static_cast<uint32_t>(k)), strideV));
      const auto top = hn::ShiftRight<8>(RandomBitsV(du, key, dimension));  // < 2^24: exact as int32 and as float
      hn::StoreU(hn::Mul(hn::ConvertTo(df, hn::BitCast(di, top)), hn::Set(df, 0x1.0p-24f)), df, o + k);
    }
    for (; k < count; ++k) o[k] = UniformFloat(key, rowFirst + static_cast<uint32_t>(k) * stride);
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
HWY_EXPORT(UniformKernel);

void UniformFloatsScalar(const RngKey& key, uint32_t first, uint32_t stride, size_t count, float* out, size_t rows,
                         uint32_t rowStride) {
  for (size_t r = 0; r < rows; ++r)
    for (size_t k = 0; k < count; ++k)
      out[r * count + k] =
          UniformFloat(key, first + static_cast<uint32_t>(r) * rowStride + static_cast<uint32_t>(k) * stride);
}

void UniformFloats(const RngKey& key, uint32_t first, uint32_t stride, size_t count, float* out, size_t rows,
                   uint32_t rowStride) {
  if (UseScalarTwins()) return UniformFloatsScalar(key, first, stride, count, out, rows, rowStride);
  HWY_DYNAMIC_DISPATCH(UniformKernel)(key, first, stride, count, out, rows, rowStride);
}

void RobertsCoordinatesScalar(const float* shifts, size_t copies, size_t count, double alpha, float* out) {
  for (size_t r = 0; r < copies; ++r)
    for (size_t k = 0; k < count; ++k)
      out[r * count + k] = RobertsCoordinate(shifts[r], static_cast<int>(k), alpha);
}

void RobertsCoordinates(const float* shifts, size_t copies, size_t count, double alpha, float* out) {
  if (UseScalarTwins()) return RobertsCoordinatesScalar(shifts, copies, count, alpha, out);
  HWY_DYNAMIC_DISPATCH(QmcKernel)(shifts, copies, count, alpha, out);
}

const char* QmcKernelDispatchedTargetName() {
  if (UseScalarTwins()) return "scalar";
  return HWY_DYNAMIC_DISPATCH(QmcKernelTargetName)();
}

}  // namespace restir

#endif  // HWY_ONCE
