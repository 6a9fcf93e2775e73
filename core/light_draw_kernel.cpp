// Highway kernel, scalar twin and dispatcher of the light-draw kernel (core/light_draw_kernel.h). The
// per-target part is compiled once per Highway target (foreach_target.h); the rest once (HWY_ONCE).
//
// Bit-exactness (DESIGN §3): the cdf inversion returns what core/sampling.h SampleCdf does (a coarse count, then
// its halving within a window: SampleCdfV), the point, the contribution and the ray are the
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
  VF invTotal;  // 1 / cdf[n - 1], as CdfPmf multiplies by it
  VF total;     // cdf[n - 1]
};

// The receiver in every lane, its BSDF the frame table's entry.
HWY_INLINE ShadingPointV BroadcastReceiverV(const LightDrawReceiver& r, const BsdfSoa& materials) {
  return BroadcastShadingPointV(r.position, r.geometricNormal, r.shadingNormal, r.wo,
                                materials.At(static_cast<size_t>(r.materialId)));
}

// The records (WriteLightDrawRecord's fields) of lights `id`, one field per register.
HWY_INLINE void LoadLightRecordsV(const float* records, VI id, VF (&r)[16]) {
#if HWY_TARGET != HWY_SCALAR
  LoadRecords16(records, id, r);
#else
  for (size_t f = 0; f < kLightDrawRecordFloats; ++f)
    r[f] = hn::GatherIndex(DF(), records + f, hn::Mul(id, hn::Set(DI(), static_cast<int32_t>(kLightDrawRecordFloats))));
#endif
}

// SampleCdf per lane, in half its dependent gathers. For a non-decreasing cdf SampleCdf returns A = #{i : cdf[i]
// <= target}, at most n - 1 (its halving keeps cdf[lo - 1] <= target < cdf[lo + len - 1]); so does this. A coarse
// count over every S-th entry (S a power of two, at least 8, at most 16 such entries; broadcast compares, no
// gathers) puts A in [lo, lo + S); SampleCdf's halving over that window, whose entries at n or beyond count as
// above the target, gives A, with log2(S) + 1 gathers where the full halving takes about log2(n) + 1 (at 72
// entries, before short tables took the path below, a third of the kernel's time waited on the halving's gathers:
// perf annotate). Tables of at most 96 entries, the flagship's 72 light groups among them, are counted whole
// without gathers. Every lane halves the same lengths, only its lower bound differs.
HWY_INLINE VI SampleCdfV(const float* cdf, size_t n, VF target) {
  const DF df;
  const DI di;
  if (n <= 96) {
    // A full count of the entries at or below the target: no gathers, four independent running counts (each a
    // chain of dependent adds).
    const VI one = hn::Set(di, 1);
    VI below[4] = {hn::Zero(di), hn::Zero(di), hn::Zero(di), hn::Zero(di)};
    size_t j = 0;
    for (; j + 4 <= n; j += 4)
      for (size_t a = 0; a < 4; ++a) {
        const auto atOrBelow = hn::RebindMask(di, hn::Le(hn::Set(df, cdf[j + a]), target));
        below[a] = hn::IfThenElse(atOrBelow, hn::Add(below[a], one), below[a]);
      }
    for (; j < n; ++j) {
      const auto atOrBelow = hn::RebindMask(di, hn::Le(hn::Set(df, cdf[j]), target));
      below[0] = hn::IfThenElse(atOrBelow, hn::Add(below[0], one), below[0]);
    }
    const VI count = hn::Add(hn::Add(below[0], below[1]), hn::Add(below[2], below[3]));
    return hn::Min(count, hn::Set(di, static_cast<int32_t>(n - 1)));
  }
  size_t stride = 8;
  while (n / stride > 16) stride *= 2;
  VI coarse = hn::Zero(di);
  for (size_t j = stride - 1; j < n; j += stride)
    coarse = hn::Sub(coarse, hn::VecFromMask(di, hn::RebindMask(di, hn::Le(hn::Set(df, cdf[j]), target))));
  VI lo = hn::Mul(coarse, hn::Set(di, static_cast<int32_t>(stride)));
  const VI count = hn::Set(di, static_cast<int32_t>(n));
  const VI last = hn::Set(di, static_cast<int32_t>(n - 1));
  // cdf[i] <= target, false for i >= n.
  const auto atOrBelow = [&](VI i) {
    const VF v = hn::GatherIndex(df, cdf, hn::Min(i, last));
    return hn::And(hn::RebindMask(di, hn::Le(v, target)), hn::Lt(i, count));
  };
  for (size_t len = stride; len > 1;) {
    const size_t half = len / 2;
    lo = hn::IfThenElse(atOrBelow(hn::Add(lo, hn::Set(di, static_cast<int32_t>(half - 1)))),
                        hn::Add(lo, hn::Set(di, static_cast<int32_t>(half))), lo);
    len -= half;
  }
  return hn::Min(hn::Add(lo, hn::IfThenElseZero(atOrBelow(lo), hn::Set(di, 1))), last);
}

// Draws [k, k + Lanes) of the uniforms (those of `valid` lanes); the ones that count are appended to out at
// `written`, which grows by their number. Writes Lanes entries from `written` on (CompressStore may fill the
// lanes after the last kept one), so the caller keeps written + Lanes within the arrays.
HWY_INLINE void DrawPacket(const DrawContext& ctx, const LightDrawLights& L, const float* cdf, const float* uSelect,
                           const float* uPoint0, const float* uPoint1, MF valid, float* const (&term)[3],
                           float* const (&out)[7], uint32_t* draw, uint32_t firstDraw, size_t k, size_t& written) {
  const DF df;
  const DI di;
  const VF zero = hn::Zero(df);
  const VF target = hn::Mul(hn::LoadU(df, uSelect + k), ctx.total);
  const VI group = SampleCdfV(cdf, L.groups, target);

  // SampleSplitCdf's triangle in the group, CdfPmf, then the area density.
  const VF at = hn::GatherIndex(df, cdf, group);
  const MF notFirst = hn::RebindMask(df, hn::Gt(group, hn::Zero(di)));
  const VF before = hn::IfThenElseZero(
      notFirst, hn::GatherIndex(df, cdf, hn::Max(hn::Sub(group, hn::Set(di, 1)), hn::Zero(di))));
  const VF step = hn::Sub(at, before);
  const VF split = hn::GatherIndex(df, L.groupSplit, group);
  const MF second = hn::Ge(hn::Sub(target, before), hn::Mul(split, step));
  const VI first = hn::GatherIndex(di, reinterpret_cast<const int32_t*>(L.groupFirst), group);
  const VI id = hn::Add(first, hn::IfThenElseZero(hn::RebindMask(di, second), hn::Set(di, 1)));
  const VF pmf = hn::Mul(step, ctx.invTotal);
  VF r[16];
  LoadLightRecordsV(L.records, id, r);
  const VF pdf = hn::Mul(pmf, r[15]);  // r[15] = 1 / area
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
  const LightPathV path = ConnectToLightOnPlaneV(ctx.sp, y, ny, p0);
  VF f[3];
  UnshadowedContributionV(ctx.sp, path, radiance, f);

  // The reference's test: (f.x > 0 || f.y > 0 || f.z > 0) && pdf > 0.
  const MF counts = hn::And(
      valid,
      hn::And(hn::Or(hn::Or(hn::Gt(f[0], zero), hn::Gt(f[1], zero)), hn::Gt(f[2], zero)), hn::Gt(pdf, zero)));
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
  // Packed by one permutation of the lanes for every output, then a full store: the source lanes in order
  // (Compress of the lane indices), applied with TableLookupLanes (one vpermps / vpermd). Per output,
  // CompressStore's masked store to memory is microcoded and many times slower on AMD Zen 4 (the kernel 2.7x
  // slower on AVX-512, measured), and Highway's AVX2 Compress recomputes the permutation each time (2.3x).
  // The terms in draw order, 0 where the draw cannot count.
  for (int c = 0; c < 3; ++c) hn::StoreU(hn::IfThenElseZero(counts, CanonicalNaNV(hn::Mul(f[c], invPdf))), df, term[c] + k);
  const VI source = hn::Compress(hn::Iota(di, 0), hn::RebindMask(di, counts));
  const auto pack = hn::IndicesFromVec(df, source);
  for (int c = 0; c < 3; ++c) {
    hn::StoreU(hn::TableLookupLanes(CanonicalNaNV(rayOrg[c]), pack), df, out[c] + written);
    hn::StoreU(hn::TableLookupLanes(CanonicalNaNV(rayDir[c]), pack), df, out[3 + c] + written);
  }
  hn::StoreU(hn::TableLookupLanes(CanonicalNaNV(length), pack), df, out[6] + written);
  const hn::RebindToUnsigned<DI> du;
  hn::StoreU(hn::Add(hn::BitCast(du, source), hn::Set(du, static_cast<uint32_t>(k) + firstDraw)), du, draw + written);
  written += hn::CountTrue(df, counts);
}

}  // namespace

size_t LightDrawKernel(const LightDrawReceiver& r, const BsdfSoa& materials, const LightDrawLights& lights,
                       const float* cdf, const LightDraws& draws, const LightDrawOutputs& out) {
  const DF df;
  const size_t N = hn::Lanes(df);
  // Initialised in place: the broadcast receiver is some thirty registers' worth, not copied once per call.
  const DrawContext ctx{BroadcastReceiverV(r, materials),        materials.At(static_cast<size_t>(r.materialId)),
                        r.bsdfMis,
                        hn::Set(df, r.errorScale),
                        hn::Set(df, 1.0f / cdf[lights.groups - 1]), hn::Set(df, cdf[lights.groups - 1])};

  float* const term[3] = {out.term[0], out.term[1], out.term[2]};
  float* const o[7] = {out.org[0], out.org[1], out.org[2], out.dir[0], out.dir[1], out.dir[2], out.tmax};
  // A full packet at k writes [written, written + N) with written <= k, inside the caller's draws.count entries.
  size_t k = 0, written = 0;
  for (; k + N <= draws.count; k += N)
    DrawPacket(ctx, lights, cdf, draws.uSelect, draws.uPoint0, draws.uPoint1, hn::FirstN(df, N), term, o, out.draw,
               out.firstDraw, k, written);
  if (k == draws.count) return written;

  // Tail: a full packet would read past the caller's uniforms and could write past its outputs, so run one on
  // padded copies (uniforms 0, valid draws whose lanes are masked off) and keep what counts.
  constexpr size_t kMax = hn::MaxLanes(DF());
  const size_t rest = draws.count - k;
  HWY_ALIGN float u[3][kMax] = {};
  for (size_t l = 0; l < rest; ++l) {
    u[0][l] = draws.uSelect[k + l];
    u[1][l] = draws.uPoint0[k + l];
    u[2][l] = draws.uPoint1[k + l];
  }
  HWY_ALIGN float paddedTerm[3][kMax];
  HWY_ALIGN float padded[7][kMax];
  HWY_ALIGN uint32_t index[kMax];
  float* const t[3] = {paddedTerm[0], paddedTerm[1], paddedTerm[2]};
  float* const p[7] = {padded[0], padded[1], padded[2], padded[3], padded[4], padded[5], padded[6]};
  size_t kept = 0;
  DrawPacket(ctx, lights, cdf, u[0], u[1], u[2], hn::FirstN(df, rest), t, p, index, 0, 0, kept);
  for (size_t l = 0; l < rest; ++l)
    for (int c = 0; c < 3; ++c) term[c][k + l] = paddedTerm[c][l];
  for (size_t l = 0; l < kept; ++l) {
    for (int f = 0; f < 7; ++f) o[f][written + l] = padded[f][l];
    out.draw[written + l] = index[l] + static_cast<uint32_t>(k) + out.firstDraw;
  }
  return written + kept;
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

namespace {

// The twins' receiver: the ShadingPoint the kernels broadcast.
ShadingPoint ReceiverPoint(const LightDrawReceiver& r, const BsdfSoa& materials) {
  ShadingPoint sp;
  sp.position = r.position;
  sp.geometricNormal = r.geometricNormal;
  sp.shadingNormal = r.shadingNormal;
  sp.wo = r.wo;
  sp.bsdf = materials.At(static_cast<size_t>(r.materialId));
  sp.errorScale = r.errorScale;
  return sp;
}

}  // namespace

size_t DrawLightSamplesScalar(const LightDrawReceiver& r, const BsdfSoa& materials, const LightDrawLights& L,
                              const float* cdf, const LightDraws& draws, const LightDrawOutputs& out) {
  const ShadingPoint sp = ReceiverPoint(r, materials);
  size_t written = 0;
  for (size_t k = 0; k < draws.count; ++k) {
    const uint32_t id = SampleSplitCdf(cdf, L.groups, L.groupFirst, L.groupSplit, draws.uSelect[k]);
    float invArea;
    const LightTriangle t = ReadLightDrawRecord(L.records + kLightDrawRecordFloats * id, invArea);
    LightSample y;
    y.lightId = id;
    y.position = SampleTrianglePoint(t, draws.uPoint0[k], draws.uPoint1[k]);
    y.normal = t.normal;
    y.radiance = t.radiance;
    y.pdfArea = CdfPmf(cdf, L.groups, SampleCdf(cdf, L.groups, draws.uSelect[k])) * invArea;
    const LightPath path = ConnectToLightOnPlane(sp, y.position, y.normal, t.p0);
    const Vec3 f = ContributionAlong(sp, y.radiance, path);
    for (int c = 0; c < 3; ++c) out.term[c][k] = 0.0f;
    if (!((f.x > 0.0f || f.y > 0.0f || f.z > 0.0f) && y.pdfArea > 0.0f)) continue;
    float weight = 1.0f;
    if (r.bsdfMis) {
      const float pLight = y.pdfArea * path.distance * path.distance / path.cosY;
      weight = PowerHeuristic(pLight, PdfBsdf(sp.bsdf, sp.shadingNormal, sp.wo, path.wi));
    }
    const Vec3 term = f * (weight / y.pdfArea);
    const ShadowRaySegment s =
        ShadowRaySetup(sp.position, sp.geometricNormal, sp.errorScale, y.position, y.normal, L.errorScale[id]);
    for (int c = 0; c < 3; ++c) {
      out.term[c][k] = CanonicalNaN(term[c]);
      out.org[c][written] = CanonicalNaN(s.org[c]);
      out.dir[c][written] = CanonicalNaN(s.dir[c]);
    }
    out.tmax[written] = CanonicalNaN(s.tmax);
    out.draw[written] = static_cast<uint32_t>(k) + out.firstDraw;
    ++written;
  }
  return written;
}

size_t DrawLightSamples(const LightDrawReceiver& receiver, const BsdfSoa& materials,
                        const LightDrawLights& lights, const float* cdf, const LightDraws& draws,
                        const LightDrawOutputs& out) {
  if (UseScalarTwins()) return DrawLightSamplesScalar(receiver, materials, lights, cdf, draws, out);
  return HWY_DYNAMIC_DISPATCH(LightDrawKernel)(receiver, materials, lights, cdf, draws, out);
}

const char* LightDrawKernelDispatchedTargetName() {
  if (UseScalarTwins()) return "scalar";
  return HWY_DYNAMIC_DISPATCH(LightDrawKernelTargetName)();
}

}  // namespace restir

#endif  // HWY_ONCE
