// Highway kernel, scalar twin and dispatcher of the light-draw kernel (core/light_draw_kernel.h). The
// per-target part is compiled once per Highway target (foreach_target.h); the rest once (HWY_ONCE).
//
// Bit-exactness (DESIGN §3): the cdf inversion is core/sampling.h SampleCdf's search lane by lane (every lane
// halves the same lengths, only its lower bound differs), the point, the contribution and the ray are the
// shared SIMD forms of their scalar equations (core/light-inl.h, core/shading-inl.h, core/shadow_ray-inl.h),
// and the receiver is broadcast, so every target reproduces the twin bit for bit. NaN results are the one
// thing the source cannot pin down; both sides canonicalise them.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/light_draw_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "hwy/highway.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/light-inl.h"
#include "core/light.h"
#include "core/light_draw_kernel.h"
#include "core/sampling.h"
#include "core/shading-inl.h"
#include "core/shading.h"
#include "core/shadow_ray-inl.h"
#include "core/shadow_ray.h"
#include "core/simd.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {
namespace {

// What every packet of one call shares: the broadcast receiver and the distribution's total.
struct DrawContext {
  ShadingPointV sp;  // the receiver in every lane
  Bsdf bsdf;         // the receiver's, for PdfBsdfUniformV
  bool bsdfMis;      // LightDrawReceiver::bsdfMis
  VF errorScale;     // the receiver's error scale (ShadowRaySetup)
  VF total;  // cdf[n - 1]
};

// SampleCdf per lane: every lane halves the same lengths, only its lower bound differs.
HWY_INLINE VI SampleCdfV(const float* cdf, size_t n, VF target) {
  const DI di;
  VI lo = hn::Zero(di);
  for (size_t len = n; len > 1;) {
    const size_t half = len / 2;
    const VF v = hn::GatherIndex(DF(), cdf, hn::Add(lo, hn::Set(di, static_cast<int32_t>(half - 1))));
    lo = hn::IfThenElse(hn::RebindMask(di, hn::Le(v, target)), hn::Add(lo, hn::Set(di, static_cast<int32_t>(half))),
                        lo);
    len -= half;
  }
  const VF atLo = hn::GatherIndex(DF(), cdf, lo);
  return hn::Min(hn::Add(lo, hn::IfThenElseZero(hn::RebindMask(di, hn::Le(atLo, target)), hn::Set(di, 1))),
                 hn::Set(di, static_cast<int32_t>(n - 1)));
}

// Draws [k, k + Lanes) of the uniforms, written to out at the same offsets.
HWY_INLINE void DrawPacket(const DrawContext& ctx, const LightDrawLights& L, const float* cdf, const float* uSelect,
                           const float* uPoint0, const float* uPoint1, float* const (&out)[10], uint8_t* traced,
                           size_t k) {
  const DF df;
  const DI di;
  const VF zero = hn::Zero(df);
  const VI id = SampleCdfV(cdf, L.count, hn::Mul(hn::LoadU(df, uSelect + k), ctx.total));

  // CdfPmf, then the area density.
  const VF at = hn::GatherIndex(df, cdf, id);
  const MF notFirst = hn::RebindMask(df, hn::Gt(id, hn::Zero(di)));
  const VF before = hn::IfThenElseZero(
      notFirst, hn::GatherIndex(df, cdf, hn::Max(hn::Sub(id, hn::Set(di, 1)), hn::Zero(di))));
  const VF pmf = hn::Div(hn::Sub(at, before), ctx.total);
  VF r[16];
#if HWY_TARGET != HWY_SCALAR
  LoadRecords16(L.records, id, r);
#else
  for (size_t f = 0; f < kLightDrawRecordFloats; ++f)
    r[f] = hn::GatherIndex(df, L.records + f,
                           hn::Mul(id, hn::Set(di, static_cast<int32_t>(kLightDrawRecordFloats))));
#endif
  const VF pdf = hn::Div(pmf, r[15]);
  VF p0[3], e1[3], e2[3], ny[3], radiance[3];
  for (int c = 0; c < 3; ++c) {
    p0[c] = r[c];
    e1[c] = r[3 + c];
    e2[c] = r[6 + c];
    ny[c] = r[9 + c];
    radiance[c] = r[12 + c];
  }
  VF y[3];
  SampleTrianglePointV(p0, e1, e2, hn::LoadU(df, uPoint0 + k), hn::LoadU(df, uPoint1 + k), y);
  const LightPathV path = ConnectToLightV(ctx.sp, y, ny);
  VF f[3];
  UnshadowedContributionV(ctx.sp, path, radiance, f);

  // The reference's test: (f.x > 0 || f.y > 0 || f.z > 0) && pdf > 0.
  const MF counts =
      hn::And(hn::Or(hn::Or(hn::Gt(f[0], zero), hn::Gt(f[1], zero)), hn::Gt(f[2], zero)), hn::Gt(pdf, zero));
  // Its term f * (weight / pdf): under MIS the weight is PowerHeuristic(pdf d² / cos θy, PdfBsdf), else 1.
  VF weight = hn::Set(df, 1.0f);
  if (ctx.bsdfMis) {
    const VF pLight = hn::Div(hn::Mul(hn::Mul(pdf, path.distance), path.distance), path.cosY);
    weight = PowerHeuristicV(pLight, PdfBsdfUniformV(ctx.bsdf, ctx.sp, path));
  }
  const VF invPdf = hn::Div(weight, pdf);
  VF rayOrg[3], rayDir[3], length;
  ShadowRaySetupV(ctx.sp.x, ctx.sp.ng, ctx.errorScale, y, ny, hn::GatherIndex(df, L.errorScale, id), rayOrg,
                  rayDir, length);
  for (int c = 0; c < 3; ++c) {
    hn::StoreU(CanonicalNaNV(hn::IfThenElseZero(counts, hn::Mul(f[c], invPdf))), df, out[c] + k);
    hn::StoreU(CanonicalNaNV(hn::IfThenElseZero(counts, rayOrg[c])), df, out[3 + c] + k);
    hn::StoreU(CanonicalNaNV(hn::IfThenElseZero(counts, rayDir[c])), df, out[6 + c] + k);
  }
  hn::StoreU(CanonicalNaNV(hn::IfThenElseZero(counts, length)), df, out[9] + k);
  HWY_ALIGN int32_t flags[hn::MaxLanes(DI())];
  hn::Store(hn::VecFromMask(di, hn::RebindMask(di, counts)), di, flags);
  for (size_t l = 0; l < hn::Lanes(df); ++l) traced[k + l] = flags[l] != 0 ? 1 : 0;
}

}  // namespace

void LightDrawKernel(const LightDrawReceiver& r, const BsdfSoa& materials, const LightDrawLights& lights,
                     const float* cdf, const LightDraws& draws, const LightDrawOutputs& out) {
  const DF df;
  const DI di;
  const size_t N = hn::Lanes(df);
  DrawContext ctx;
  VF x[3], ng[3], ns[3], wo[3];
  for (int c = 0; c < 3; ++c) {
    x[c] = hn::Set(df, r.position[c]);
    ng[c] = hn::Set(df, r.geometricNormal[c]);
    ns[c] = hn::Set(df, r.shadingNormal[c]);
    wo[c] = hn::Set(df, r.wo[c]);
  }
  ctx.sp = MakeShadingPointV(x, ng, ns, wo, GatherBsdfV(materials, hn::Set(di, r.materialId)));
  ctx.bsdf = materials.At(static_cast<size_t>(r.materialId));
  ctx.bsdfMis = r.bsdfMis;
  ctx.errorScale = hn::Set(df, r.errorScale);
  ctx.total = hn::Set(df, cdf[lights.count - 1]);

  float* const o[10] = {out.term[0], out.term[1], out.term[2], out.org[0], out.org[1],
                        out.org[2],  out.dir[0],  out.dir[1],  out.dir[2], out.tmax};
  size_t k = 0;
  for (; k + N <= draws.count; k += N)
    DrawPacket(ctx, lights, cdf, draws.uSelect, draws.uPoint0, draws.uPoint1, o, out.traced, k);
  if (k == draws.count) return;

  // Tail: a full packet would read and write past the caller's arrays, so run one on a padded copy (uniforms
  // 0: valid draws whose results are dropped).
  constexpr size_t kMax = hn::MaxLanes(DF());
  const size_t rest = draws.count - k;
  HWY_ALIGN float u[3][kMax] = {};
  for (size_t l = 0; l < rest; ++l) {
    u[0][l] = draws.uSelect[k + l];
    u[1][l] = draws.uPoint0[k + l];
    u[2][l] = draws.uPoint1[k + l];
  }
  HWY_ALIGN float padded[10][kMax];
  HWY_ALIGN uint8_t t[kMax];
  float* const p[10] = {padded[0], padded[1], padded[2], padded[3], padded[4],
                        padded[5], padded[6], padded[7], padded[8], padded[9]};
  DrawPacket(ctx, lights, cdf, u[0], u[1], u[2], p, t, 0);
  for (size_t l = 0; l < rest; ++l) {
    for (int f = 0; f < 10; ++f) o[f][k + l] = padded[f][l];
    out.traced[k + l] = t[l];
  }
}

const char* LightDrawKernelTargetName() {
  return hwy::TargetName(HWY_TARGET);
}

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#if HWY_ONCE

namespace restir {

HWY_EXPORT(LightDrawKernel);
HWY_EXPORT(LightDrawKernelTargetName);

void DrawLightSamplesScalar(const LightDrawReceiver& r, const BsdfSoa& materials, const LightDrawLights& L,
                            const float* cdf, const LightDraws& draws, const LightDrawOutputs& out) {
  ShadingPoint sp;
  sp.position = r.position;
  sp.geometricNormal = r.geometricNormal;
  sp.shadingNormal = r.shadingNormal;
  sp.wo = r.wo;
  sp.bsdf = materials.At(static_cast<size_t>(r.materialId));
  sp.errorScale = r.errorScale;
  for (size_t k = 0; k < draws.count; ++k) {
    const uint32_t id = SampleCdf(cdf, L.count, draws.uSelect[k]);
    const LightTriangle t = ReadLightDrawRecord(L.records + kLightDrawRecordFloats * id);
    LightSample y;
    y.lightId = id;
    y.position = SampleTrianglePoint(t, draws.uPoint0[k], draws.uPoint1[k]);
    y.normal = t.normal;
    y.radiance = t.radiance;
    y.pdfArea = CdfPmf(cdf, L.count, id) / t.area;
    const Vec3 f = UnshadowedContribution(sp, y);
    const bool counts = (f.x > 0.0f || f.y > 0.0f || f.z > 0.0f) && y.pdfArea > 0.0f;
    out.traced[k] = counts ? 1 : 0;
    Vec3 term(0.0f);
    ShadowRaySegment s;
    s.org = s.dir = Vec3(0.0f);
    if (counts) {
      float weight = 1.0f;
      if (r.bsdfMis) {
        const LightPath path = ConnectToLight(sp, y.position, y.normal);
        const float cosY = -glm::dot(y.normal, path.wi);
        const float pLight = y.pdfArea * path.distance * path.distance / cosY;
        weight = PowerHeuristic(pLight, PdfBsdf(sp.bsdf, sp.shadingNormal, sp.wo, path.wi));
      }
      term = f * (weight / y.pdfArea);
      s = ShadowRaySetup(sp.position, sp.geometricNormal, sp.errorScale, y.position, y.normal,
                         L.errorScale[id]);
    }
    for (int c = 0; c < 3; ++c) {
      out.term[c][k] = CanonicalNaN(term[c]);
      out.org[c][k] = CanonicalNaN(s.org[c]);
      out.dir[c][k] = CanonicalNaN(s.dir[c]);
    }
    out.tmax[k] = CanonicalNaN(s.tmax);
  }
}

void DrawLightSamples(const LightDrawReceiver& receiver, const BsdfSoa& materials,
                      const LightDrawLights& lights, const float* cdf, const LightDraws& draws,
                      const LightDrawOutputs& out) {
  if (UseScalarTwins()) return DrawLightSamplesScalar(receiver, materials, lights, cdf, draws, out);
  HWY_DYNAMIC_DISPATCH(LightDrawKernel)(receiver, materials, lights, cdf, draws, out);
}

const char* LightDrawKernelDispatchedTargetName() {
  if (UseScalarTwins()) return "scalar";
  return HWY_DYNAMIC_DISPATCH(LightDrawKernelTargetName)();
}

}  // namespace restir

#endif  // HWY_ONCE
