// FLIP's per-row stages (sim/metrics/flip_internal.h) in Highway, compiled once per target (foreach_target.h) and
// dispatched to the best one. Each lane runs the scalar formulas of sim/metrics/flip_internal.h operation for
// operation: Mul and Add apart (never MulAdd, which fuses on AVX2), Div and Sqrt (exactly rounded on every target),
// double where the scalar code computes in double, and selects for the branches. So every target gives the same bits.
// (BoundsRow's approximations are the one exception, and harmless: they choose which values get computed, never a
// value.)
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "sim/metrics/flip_rows.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "hwy/highway.h"
#include "hwy/contrib/math/math-inl.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "sim/metrics/flip_internal.h"

HWY_BEFORE_NAMESPACE();
namespace restir::flip_detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using DF = hn::ScalableTag<float>;  // the correlations: full vectors of floats
using DD = hn::ScalableTag<double>;
using DH = hn::Rebind<float, DD>;  // the point-wise stages: one double vector's worth of floats
using DHI = hn::RebindToSigned<DH>;
using DHU = hn::RebindToUnsigned<DH>;
using VF = hn::Vec<DF>;
using VD = hn::Vec<DD>;
using VH = hn::Vec<DH>;

HWY_INLINE VH Sf(float v) { return hn::Set(DH(), v); }
HWY_INLINE VD Sd(double v) { return hn::Set(DD(), v); }
HWY_INLINE VD Promote(VH v) { return hn::PromoteTo(DD(), v); }
HWY_INLINE VH Demote(VD v) { return hn::DemoteTo(DH(), v); }
HWY_INLINE VF Ff(float v) { return hn::Set(DF(), v); }

// m[0] a + m[1] b + m[2] c, summed left to right.
HWY_INLINE VF Dot3F(const float m[3], VF a, VF b, VF c) {
  return hn::Add(hn::Add(hn::Mul(Ff(m[0]), a), hn::Mul(Ff(m[1]), b)), hn::Mul(Ff(m[2]), c));
}

// Clamp01: v > 0 ? (v < 1 ? v : 1) : 0 (NaN -> 0).
HWY_INLINE VF Clamp01F(VF v) {
  const VF one = Ff(1.0f);
  return hn::IfThenElseZero(hn::Gt(v, hn::Zero(DF())), hn::IfThenElse(hn::Lt(v, one), v, one));
}

// ToneMapX, rounded to float.
HWY_INLINE VH ToneMapV(VD x) {
  const VD one = Sd(1.0);
  const VD num = hn::Add(hn::Add(hn::Mul(hn::Mul(Sd(kTm0), x), x), hn::Mul(Sd(kTm1), x)), Sd(kTm2));
  const VD den = hn::Add(hn::Add(hn::Mul(hn::Mul(Sd(kTm3), x), x), hn::Mul(Sd(kTm4), x)), Sd(kTm5));
  const VD y = hn::Div(num, den);
  const VD clamped = hn::IfThenElse(hn::Lt(one, y), one, y);  // std::min(y, 1.0)
  const VD mapped = hn::IfThenElse(hn::Gt(x, Sd(kToneMapHuge)), one, clamped);
  return Demote(hn::IfThenElseZero(hn::Gt(x, hn::Zero(DD())), mapped));
}

// glibc 2.36's cbrtf (sysdeps/ieee754/flt-32/s_cbrtf.c) for positive normal x, its double steps kept: x = xm 2^xe
// with xm in [0.5, 1); u = float(p(xm)); t2 = u u u in float; ym = float(u (t2 + 2 xm) / (2 t2 + xm) 2^((xe % 3)/3));
// result ldexpf(ym, xe / 3), an exact scaling here. Checked equal to std::cbrt for every positive normal float
// (tests/sim/metrics/flip_legacy_test.cpp samples that check over the range FLIP reaches).
HWY_INLINE VH CbrtV(VH x) {
  const DHI di;
  const DHU du;
  const auto bits = hn::BitCast(du, x);
  const auto xe = hn::Sub(hn::BitCast(di, hn::ShiftRight<23>(bits)), hn::Set(di, 126));
  const VH xm = hn::BitCast(DH(), hn::Or(hn::And(bits, hn::Set(du, 0x7fffffu)), hn::Set(du, 0x3f000000u)));
  const VD xmd = Promote(xm);
  const VH u = Demote(hn::Add(
      Sd(0.492659620528969547),
      hn::Mul(hn::Sub(Sd(0.697570460207922770), hn::Mul(Sd(0.191502161678719066), xmd)), xmd)));
  const VH t2 = hn::Mul(hn::Mul(u, u), u);
  const VD t2d = Promote(t2);
  // xe / 3 and xe % 3 as C computes them (truncating). For |xe| <= 128, xe times float(1/3) (rounded up) lies
  // strictly between the truncated quotient and the next integer away from zero, so truncating it is exact.
  const auto q = hn::ConvertTo(di, hn::Mul(hn::ConvertTo(DH(), xe), Sf(1.0f / 3.0f)));
  const auto r = hn::Sub(xe, hn::Mul(q, hn::Set(di, 3)));
  constexpr double kCbrt2 = 1.2599210498948731648, kSqrCbrt2 = 1.5874010519681994748;
  const VH rf = hn::ConvertTo(DH(), r);
  const VD rd = Promote(rf);
  VD factor = Sd(1.0);
  factor = hn::IfThenElse(hn::Eq(rd, Sd(-2.0)), Sd(1.0 / kSqrCbrt2), factor);
  factor = hn::IfThenElse(hn::Eq(rd, Sd(-1.0)), Sd(1.0 / kCbrt2), factor);
  factor = hn::IfThenElse(hn::Eq(rd, Sd(1.0)), Sd(kCbrt2), factor);
  factor = hn::IfThenElse(hn::Eq(rd, Sd(2.0)), Sd(kSqrCbrt2), factor);
  const VD ud = Promote(u);
  const VH ym = Demote(hn::Mul(
      hn::Div(hn::Mul(ud, hn::Add(t2d, hn::Mul(Sd(2.0), xmd))), hn::Add(hn::Mul(Sd(2.0), t2d), xmd)), factor));
  const VH scale = hn::BitCast(DH(), hn::ShiftLeft<23>(hn::Add(q, hn::Set(di, 127))));
  return hn::Mul(ym, scale);
}

// CbrtV on full vectors, a half at a time (HWY_SCALAR's one lane at once).
#if HWY_TARGET == HWY_SCALAR
static_assert(std::is_same_v<DH, DF>, "one lane of each");
HWY_INLINE VF CbrtFull(VF x) { return CbrtV(x); }
#else
static_assert(std::is_same_v<DH, hn::Half<DF>>, "a double vector holds half a float vector");
HWY_INLINE VF CbrtFull(VF x) {
  return hn::Combine(DF(), CbrtV(hn::UpperHalf(DH(), x)), CbrtV(hn::LowerHalf(DH(), x)));
}
#endif

// Lab's f(t) per lane.
HWY_INLINE VF LabF(VF t) {
  return hn::IfThenElse(hn::Gt(t, Ff(kLabDeltaCube)), CbrtFull(t), hn::Add(hn::Mul(Ff(kLabFactor), t), Ff(kLabOffset)));
}

// Scalar PrepareRow pixel (the row's last pixels, where a whole vector would read past the image).
inline void PreparePixel(const float* rgb, double scale, float* yy, float* cx, float* cz, float* lum) {
  float c[3];
  for (int k = 0; k < 3; ++k)
    c[k] = scale > 0.0 ? static_cast<float>(ToneMapX(scale * double(rgb[k]))) : Clamp01(rgb[k]);
  const Color3 o = LinearRgbToYcxcz(c[0], c[1], c[2]);
  *yy = o.v[0];
  *cx = o.v[1];
  *cz = o.v[2];
  *lum = (o.v[0] + 16.0f) / 116.0f;
}

// ToneMapV of scale * v on full vectors, a half at a time.
HWY_INLINE VF ToneMapFull(VF v, VD scale) {
#if HWY_TARGET == HWY_SCALAR
  return ToneMapV(hn::Mul(scale, Promote(v)));
#else
  return hn::Combine(DF(), ToneMapV(hn::Mul(scale, Promote(hn::UpperHalf(DH(), v)))),
                     ToneMapV(hn::Mul(scale, Promote(hn::LowerHalf(DH(), v)))));
#endif
}

void PrepareRowImpl(const float* rgb, int width, double scale, float* yy, float* cx, float* cz, float* lum) {
  const DF df;
  const int n = static_cast<int>(hn::Lanes(df));
  const VD scaleV = Sd(scale);
  int x = 0;
  for (; x + n <= width; x += n) {
    VF c[3];
    hn::LoadInterleaved3(df, rgb + 3 * static_cast<size_t>(x), c[0], c[1], c[2]);
    for (VF& v : c) v = scale > 0.0 ? ToneMapFull(v, scaleV) : Clamp01F(v);
    const VF xs = hn::Mul(Dot3F(kRgbToXyz[0], c[0], c[1], c[2]), Ff(kInvWhite[0]));
    const VF ys = hn::Mul(Dot3F(kRgbToXyz[1], c[0], c[1], c[2]), Ff(kInvWhite[1]));
    const VF zs = hn::Mul(Dot3F(kRgbToXyz[2], c[0], c[1], c[2]), Ff(kInvWhite[2]));
    const VF y = hn::Sub(hn::Mul(Ff(116.0f), ys), Ff(16.0f));
    hn::StoreU(y, df, yy + x);
    hn::StoreU(hn::Mul(Ff(500.0f), hn::Sub(xs, ys)), df, cx + x);
    hn::StoreU(hn::Mul(Ff(200.0f), hn::Sub(ys, zs)), df, cz + x);
    hn::StoreU(hn::Div(hn::Add(y, Ff(16.0f)), Ff(116.0f)), df, lum + x);
  }
  for (; x < width; ++x) PreparePixel(rgb + 3 * static_cast<size_t>(x), scale, yy + x, cx + x, cz + x, lum + x);
}

// Kernels 0 .. kPlain - 1 summed plainly, kPlain .. kPlain + kCentred - 1 centred, all over the same taps: each
// output is CorrelateRow's sum, in its order; sharing the loads and the centred differences only saves work.
// Blocks of several vectors keep enough independent sums in flight to hide the adds' latency.
template <int kPlain, int kCentred>
HWY_INLINE void CorrelateGroup(const float* const* src, const float* const* w, int taps, const float* centre,
                               int skip, int count, float* const* out) {
  constexpr int kKernels = kPlain + kCentred;
  constexpr int kBlock = kKernels == 1 ? 4 : 2;
  const DF df;
  const int n = static_cast<int>(hn::Lanes(df));
  int x = 0;
  auto run = [&](auto block) {
    constexpr int kB = decltype(block)::value;
    VF acc[kKernels][kB];
    VF c[kB];
    for (int b = 0; b < kB; ++b) c[b] = hn::Zero(df);
    for (int b = 0; b < kB; ++b) {
      if constexpr (kCentred > 0) c[b] = hn::LoadU(df, centre + x + b * n);
      for (int k = 0; k < kKernels; ++k) acc[k][b] = hn::Zero(df);
    }
    // Tap 0 starts the plain sums (w[0] s[0], as the scalar code starts them; the centred ones start from 0).
    auto tap = [&](int t, auto first) {
      const float* st = src[t] + x;
      for (int b = 0; b < kB; ++b) {
        const VF v = hn::LoadU(df, st + b * n);
        for (int k = 0; k < kPlain; ++k) {
          const VF term = hn::Mul(hn::Set(df, w[k][t]), v);
          acc[k][b] = decltype(first)::value ? term : hn::Add(acc[k][b], term);
        }
        if constexpr (kCentred > 0) {
          if (t != skip) {
            const VF d = hn::Sub(v, c[b]);
            for (int k = kPlain; k < kKernels; ++k) acc[k][b] = hn::Add(acc[k][b], hn::Mul(hn::Set(df, w[k][t]), d));
          }
        }
      }
    };
    tap(0, std::true_type());
    for (int t = 1; t < taps; ++t) tap(t, std::false_type());
    for (int k = 0; k < kKernels; ++k)
      for (int b = 0; b < kB; ++b) hn::StoreU(acc[k][b], df, out[k] + x + b * n);
  };
  for (; x + kBlock * n <= count; x += kBlock * n) run(std::integral_constant<int, kBlock>());
  for (; x < count; x += n) run(std::integral_constant<int, 1>());
}

void CorrelateRowsImpl(const float* const* src, const float* const* w, int plain, int centred, int taps,
                       const float* centre, int skip, int count, float* const* out) {
  switch (plain * 4 + centred) {
    case 4: return CorrelateGroup<1, 0>(src, w, taps, centre, skip, count, out);
    case 1: return CorrelateGroup<0, 1>(src, w, taps, centre, skip, count, out);
    case 8: return CorrelateGroup<2, 0>(src, w, taps, centre, skip, count, out);
    case 2: return CorrelateGroup<0, 2>(src, w, taps, centre, skip, count, out);
    case 6: return CorrelateGroup<1, 2>(src, w, taps, centre, skip, count, out);
    default: HWY_ASSERT(false);
  }
}

void FeatureRowImpl(const float* const* in, float w1, float w2, int count, float* const* out) {
  const DF df;
  const int n = static_cast<int>(hn::Lanes(df));
  for (int x = 0; x < count; x += n) {
    auto load = [&](int plane) { return hn::LoadU(df, in[plane] + x); };
    // YcxczToLinearRgb of the filtered colour, clamped.
    const VF cz = hn::Add(hn::Mul(Ff(w1), load(kFiltCz1)), hn::Mul(Ff(w2), load(kFiltCz2)));
    const VF y = hn::Div(hn::Add(load(kFiltY), Ff(16.0f)), Ff(116.0f));
    const VF xx = hn::Add(y, hn::Div(load(kFiltCx), Ff(500.0f)));
    const VF z = hn::Sub(y, hn::Div(cz, Ff(200.0f)));
    const VF xw = hn::Mul(xx, Ff(kWhite[0])), yw = hn::Mul(y, Ff(kWhite[1])), zw = hn::Mul(z, Ff(kWhite[2]));
    const VF r = Clamp01F(Dot3F(kXyzToRgb[0], xw, yw, zw));
    const VF g = Clamp01F(Dot3F(kXyzToRgb[1], xw, yw, zw));
    const VF b = Clamp01F(Dot3F(kXyzToRgb[2], xw, yw, zw));
    // LinearRgbToLab, then Hunt.
    const VF f0 = LabF(hn::Mul(Dot3F(kRgbToXyz[0], r, g, b), Ff(kInvWhite[0])));
    const VF f1 = LabF(hn::Mul(Dot3F(kRgbToXyz[1], r, g, b), Ff(kInvWhite[1])));
    const VF f2 = LabF(hn::Mul(Dot3F(kRgbToXyz[2], r, g, b), Ff(kInvWhite[2])));
    const VF l = hn::Sub(hn::Mul(Ff(116.0f), f1), Ff(16.0f));
    const VF s = hn::Mul(Ff(0.01f), l);
    hn::StoreU(l, df, out[kFeatL] + x);
    hn::StoreU(hn::Mul(s, hn::Mul(Ff(500.0f), hn::Sub(f0, f1))), df, out[kFeatA] + x);
    hn::StoreU(hn::Mul(s, hn::Mul(Ff(200.0f), hn::Sub(f1, f2))), df, out[kFeatB] + x);
    const VF ex = load(kFiltEx), ey = load(kFiltEy), px = load(kFiltPx), py = load(kFiltPy);
    hn::StoreU(hn::Sqrt(hn::Add(hn::Mul(ex, ex), hn::Mul(ey, ey))), df, out[kFeatEdge] + x);
    hn::StoreU(hn::Sqrt(hn::Add(hn::Mul(px, px), hn::Mul(py, py))), df, out[kFeatPoint] + x);
  }
}

void DifferenceRowImpl(const float* const* ref, const float* const* test, int count, float* hyab,
                       float* featureDiff) {
  const DF df;
  const int n = static_cast<int>(hn::Lanes(df));
  for (int x = 0; x < count; x += n) {
    auto diff = [&](int plane) { return hn::Sub(hn::LoadU(df, ref[plane] + x), hn::LoadU(df, test[plane] + x)); };
    const VF dl = diff(kFeatL), da = diff(kFeatA), db = diff(kFeatB);
    hn::StoreU(hn::Add(hn::Abs(dl), hn::Sqrt(hn::Add(hn::Mul(da, da), hn::Mul(db, db)))), df, hyab + x);
    const VF de = hn::Abs(diff(kFeatEdge)), dp = hn::Abs(diff(kFeatPoint));
    hn::StoreU(hn::IfThenElse(hn::Lt(de, dp), dp, de), df, featureDiff + x);  // std::max(de, dp)
  }
}

// Bounds on the logarithm of each exposure's FLIP value, from approximations (Highway's Log and Exp, which fuse
// and round unlike glibc): they only choose which exposures get the exact evaluation, never a value, so they may
// differ by target. ln v = (1 - feature) ln R(hyab^q_c), R the redistribution; below p_c cmax R is linear, so
// ln R = ln(p_t / (p_c cmax)) + q_c ln hyab needs no Exp or second Log.
void BoundsRowImpl(const float* hyab, const float* featureDiff, size_t exposureStride, int exposures, int count,
                   float cmax, float* hi, float* maxLo) {
  const DF df;
  const int n = static_cast<int>(hn::Lanes(df));
  const float pcCmax = kPc * cmax;
  const VF zero = hn::Zero(df), one = Ff(1.0f), qc = Ff(kQc);
  const VF lnPcCmax = Ff(float(std::log(double(pcCmax)))), lnSlope1 = Ff(float(std::log(double(kPt / pcCmax))));
  const VF pcCmaxV = Ff(pcCmax), range2 = Ff(cmax - pcCmax), slope2 = Ff(1.0f - kPt), pt = Ff(kPt);
  const VF margin = Ff(kFlipBoundMargin), tiny = Ff(kFlipBoundTiny);
  const VF lnTiny = Ff(float(std::log(double(kFlipBoundTiny))));
  const VF inf = Ff(std::numeric_limits<float>::infinity()), invSqrt2 = Ff(float(1.0 / std::sqrt(2.0)));
  const VF nearZero = Ff(1.0f / 1048576.0f);
  for (int x = 0; x < count; x += n) {
    VF m = hn::Neg(inf);
    for (int e = 0; e < exposures; ++e) {
      const VF h = hn::LoadU(df, hyab + size_t(e) * exposureStride + x);
      // FeatureTerm in float (within 2 ulp of it): 1 - feature errs by < 3e-7, ln v by < 3e-5.
      const VF fd = hn::LoadU(df, featureDiff + size_t(e) * exposureStride + x);
      const VF f = hn::Sqrt(hn::Mul(fd, invSqrt2));
      const VF ex = hn::Sub(one, hn::IfThenElse(hn::Lt(f, one), f, one));
      const auto positive = hn::Gt(h, zero);
      const VF lnp = hn::Mul(qc, hn::Log(df, hn::IfThenElse(positive, h, one)));
      const auto linear = hn::Lt(lnp, lnPcCmax);
      VF lnR = hn::Add(lnSlope1, lnp);
      if (!hn::AllTrue(df, hn::Or(linear, hn::Not(positive)))) {
        const VF p = hn::Exp(df, lnp);
        const VF r = hn::Add(pt, hn::Mul(hn::Div(hn::Sub(p, pcCmaxV), range2), slope2));
        lnR = hn::IfThenElse(linear, lnR, hn::Log(df, hn::IfThenElse(hn::Lt(one, r), one, r)));
      }
      // hyab = 0: colour 0, so v = 0^ex: 0, or 1 where the feature term is 1 (ex = 0).
      const VF lnv = hn::IfThenElse(positive, hn::Mul(ex, lnR), hn::IfThenElseZero(hn::Gt(ex, zero), hn::Neg(inf)));
      // Left open (ln v in [-inf, 0], which always holds): hyab below `tiny`, where the relative error analysis
      // is not trusted, and hyab = 0 with the feature term so near 1 that the approximation may not tell 0^0 = 1
      // from 0^ex = 0. Below ln `tiny`, v gets no lower bound.
      const auto unsure = hn::Or(hn::And(positive, hn::Lt(h, tiny)), hn::And(hn::Not(positive), hn::Lt(ex, nearZero)));
      const VF lo = hn::IfThenElse(hn::Or(unsure, hn::Lt(lnv, lnTiny)), hn::Neg(inf), hn::Sub(lnv, margin));
      const VF up = hn::IfThenElse(unsure, margin, hn::Add(hn::IfThenElse(hn::Lt(lnv, lnTiny), lnTiny, lnv), margin));
      hn::StoreU(up, df, hi + size_t(e) * count + x);
      m = hn::Max(m, lo);
    }
    hn::StoreU(m, df, maxLo + x);
  }
}

void CbrtRowImpl(const float* in, int count, float* out) {
  const DF df;
  const int n = static_cast<int>(hn::Lanes(df));
  for (int x = 0; x < count; x += n) hn::StoreU(CbrtFull(hn::LoadU(df, in + x)), df, out + x);
}

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir::flip_detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace restir::flip_detail {

HWY_EXPORT(PrepareRowImpl);
HWY_EXPORT(CorrelateRowsImpl);
HWY_EXPORT(FeatureRowImpl);
HWY_EXPORT(DifferenceRowImpl);
HWY_EXPORT(BoundsRowImpl);
HWY_EXPORT(CbrtRowImpl);

void PrepareRow(const float* rgb, int width, double toneMapScale, float* yy, float* cx, float* cz, float* lum) {
  HWY_DYNAMIC_DISPATCH(PrepareRowImpl)(rgb, width, toneMapScale, yy, cx, cz, lum);
}

void CorrelateRows(const float* const* src, const float* const* w, int plain, int centred, int taps,
                   const float* centre, int skip, int count, float* const* out) {
  HWY_DYNAMIC_DISPATCH(CorrelateRowsImpl)(src, w, plain, centred, taps, centre, skip, count, out);
}

void CorrelateRow(const float* const* src, const float* w, int taps, const float* centre, int skip, int count,
                  float* out) {
  CorrelateRows(src, &w, centre ? 0 : 1, centre ? 1 : 0, taps, centre, skip, count, &out);
}

void FeatureRow(const float* const* filtered, float blueYellowWeight1, float blueYellowWeight2, int count,
                float* const* features) {
  HWY_DYNAMIC_DISPATCH(FeatureRowImpl)(filtered, blueYellowWeight1, blueYellowWeight2, count, features);
}

void DifferenceRow(const float* const* reference, const float* const* test, int count, float* hyab,
                   float* featureDiff) {
  HWY_DYNAMIC_DISPATCH(DifferenceRowImpl)(reference, test, count, hyab, featureDiff);
}

void BoundsRow(const float* hyab, const float* featureDiff, size_t exposureStride, int exposures, int count,
               float cmax, float* hi, float* maxLo) {
  HWY_DYNAMIC_DISPATCH(BoundsRowImpl)(hyab, featureDiff, exposureStride, exposures, count, cmax, hi, maxLo);
}

void CbrtRow(const float* in, int count, float* out) { HWY_DYNAMIC_DISPATCH(CbrtRowImpl)(in, count, out); }

}  // namespace restir::flip_detail
#endif  // HWY_ONCE
