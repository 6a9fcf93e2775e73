// Highway kernel, scalar twin and dispatcher of the BSDF-draw kernel (core/bsdf_draw_kernel.h). The per-target
// part is compiled once per Highway target (foreach_target.h); the rest once (HWY_ONCE).
//
// Bit-exactness (DESIGN §3): the receiver and its BSDF are broadcast (the model's branches are scalar), and each
// lane computes the scalar expressions of core/bsdf.cpp SampleBsdf (core/sampling.h SinCos2Pi, core/math.h
// OrthonormalBasis, GgxD, PdfBsdf through core/shading-inl.h PdfBsdfUniformV), EvalBsdf (EvalBsdfV) and
// core/shadow_ray.h OffsetRayOrigin (OffsetRayOriginV) term for term in the same order. No MulAdd. NaN results
// are canonicalised on both sides.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/bsdf_draw_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "hwy/highway.h"

#include <algorithm>
#include <cmath>

#include "core/bsdf.h"
#include "core/bsdf_draw_kernel.h"
#include "core/kernel-inl.h"
#include "core/sampling.h"
#include "core/shading-inl.h"
#include "core/shadow_ray-inl.h"
#include "core/shadow_ray.h"
#include "core/simd.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {
namespace {

// core/sampling.h SinCos2Pi.
HWY_INLINE void SinCos2PiV(VF u, VF& sine, VF& cosine) {
  const DF df;
  const DI di;
  const VI quarterTurns = hn::ConvertTo(di, hn::Add(hn::Mul(hn::Set(df, 4.0f), u), hn::Set(df, 0.5f)));
  const VF q = hn::ConvertTo(df, quarterTurns);
  const VF r = hn::Sub(u, hn::Mul(hn::Set(df, 0.25f), q));
  const VF z = hn::Mul(r, r);
  VF ps = hn::Add(hn::Mul(hn::Set(df, -75.40213012695312f), z), hn::Set(df, 81.5925521850586f));
  ps = hn::Sub(hn::Mul(ps, z), hn::Set(df, 41.3416633605957f));
  const VF s = hn::Mul(r, hn::Add(hn::Mul(ps, z), hn::Set(df, 6.2831854820251465f)));
  VF pc = hn::Add(hn::Mul(hn::Set(df, -83.59269714355469f), z), hn::Set(df, 64.92125701904297f));
  pc = hn::Sub(hn::Mul(pc, z), hn::Set(df, 19.739152908325195f));
  const VF c = hn::Add(hn::Mul(pc, z), hn::Set(df, 1.0f));
  const VI quarter = hn::And(quarterTurns, hn::Set(di, 3));
  const MF q1 = hn::RebindMask(df, hn::Eq(quarter, hn::Set(di, 1)));
  const MF q2 = hn::RebindMask(df, hn::Eq(quarter, hn::Set(di, 2)));
  const MF q3 = hn::RebindMask(df, hn::Eq(quarter, hn::Set(di, 3)));
  sine = hn::IfThenElse(q1, c, hn::IfThenElse(q2, hn::Neg(s), hn::IfThenElse(q3, hn::Neg(c), s)));
  cosine = hn::IfThenElse(q1, hn::Neg(s), hn::IfThenElse(q2, hn::Neg(c), hn::IfThenElse(q3, s, c)));
}

// What every packet of one call shares: the broadcast receiver, its BSDF and its tangent frame.
struct BsdfContext {
  ShadingPointV sp;  // the receiver in every lane
  Bsdf bsdf;         // its BSDF
  VF t[3], b[3];     // core/math.h OrthonormalBasis(n)
  VF errorScale;     // the receiver's error scale (OffsetRayOrigin)
};

// core/bsdf.cpp ToWorld: local.x t + local.y b + local.z n.
HWY_INLINE void ToWorldV(const BsdfContext& ctx, VF lx, VF ly, VF lz, VF (&out)[3]) {
  for (int c = 0; c < 3; ++c)
    out[c] = hn::Add(hn::Add(hn::Mul(lx, ctx.t[c]), hn::Mul(ly, ctx.b[c])), hn::Mul(lz, ctx.sp.n[c]));
}

// core/bsdf.cpp SampleCosineLobe: wi and pdf (every lane succeeds).
HWY_INLINE void SampleCosineLobeV(const BsdfContext& ctx, VF u0, VF u1, VF (&wi)[3], VF& pdf) {
  const DF df;
  const VF r = hn::Sqrt(u0);
  VF s, c;
  SinCos2PiV(u1, s, c);
  const VF oneMinus = hn::Sub(hn::Set(df, 1.0f), u0);
  const VF z = hn::Sqrt(hn::IfThenElse(hn::Lt(hn::Zero(df), oneMinus), oneMinus, hn::Zero(df)));  // max(0, .)
  ToWorldV(ctx, hn::Mul(r, c), hn::Mul(r, s), z, wi);
  pdf = hn::Mul(z, hn::Set(df, kInvPi));
}

// core/bsdf.cpp SampleGgxLobe: wi and pdf, pdf 0 where the sample fails.
HWY_INLINE void SampleGgxLobeV(const BsdfContext& ctx, float alpha, VF u0, VF u1, VF (&wi)[3], VF& pdf) {
  const DF df;
  const VF zero = hn::Zero(df);
  const VF one = hn::Set(df, 1.0f);
  const float a2 = alpha * alpha;
  const VF cos2 = hn::Div(hn::Sub(one, u0), hn::Add(one, hn::Mul(hn::Set(df, a2 - 1.0f), u0)));
  const auto max0 = [&](VF v) { return hn::IfThenElse(hn::Lt(zero, v), v, zero); };  // std::max(0, v)
  const VF cosH = hn::Sqrt(max0(cos2));
  const VF sinH = hn::Sqrt(max0(hn::Sub(one, cos2)));
  VF s, c, h[3];
  SinCos2PiV(u1, s, c);
  ToWorldV(ctx, hn::Mul(sinH, c), hn::Mul(sinH, s), cosH, h);
  const VF oh = Dot(ctx.sp.wo, h);
  const VF twoOh = hn::Mul(hn::Set(df, 2.0f), oh);
  for (int k = 0; k < 3; ++k) wi[k] = hn::Sub(hn::Mul(twoOh, h[k]), ctx.sp.wo[k]);
  const MF ok = hn::And(hn::Not(hn::Le(oh, zero)), hn::Not(hn::Le(Dot(ctx.sp.n, wi), zero)));
  // GgxD(cosH, alpha) cosH / (4 oh).
  const VF c2 = hn::Mul(cosH, cosH);
  const VF denom = hn::Add(hn::Mul(c2, hn::Set(df, a2 - 1.0f)), one);
  const VF d = hn::IfThenZeroElse(hn::Le(cosH, zero),
                                  hn::Div(hn::Set(df, a2), hn::Mul(hn::Mul(hn::Set(df, kPi), denom), denom)));
  pdf = hn::IfThenElseZero(ok, hn::Div(hn::Mul(d, cosH), hn::Mul(hn::Set(df, 4.0f), oh)));
}

// core/bsdf.cpp SampleBsdf for the context's BSDF.
HWY_INLINE void SampleBsdfV(const BsdfContext& ctx, VF u0, VF u1, VF (&wi)[3], VF& pdf) {
  const DF df;
  const Bsdf& bsdf = ctx.bsdf;
  if (bsdf.type == BsdfType::kDiffuse) return SampleCosineLobeV(ctx, u0, u1, wi, pdf);
  if (bsdf.type == BsdfType::kGgx) return SampleGgxLobeV(ctx, bsdf.alpha, u0, u1, wi, pdf);
  const float p = LayeredSpecularProbability(bsdf);
  const VF below = hn::Set(df, kOneMinusEpsilon);
  const auto min1 = [&](VF v) { return hn::IfThenElse(hn::Lt(below, v), below, v); };  // std::min(v, below)
  const MF specular = hn::Lt(u0, hn::Set(df, p));
  VF ggxWi[3], ggxPdf, cosWi[3], cosPdf;
  SampleGgxLobeV(ctx, bsdf.alpha, min1(hn::Div(u0, hn::Set(df, p))), u1, ggxWi, ggxPdf);
  SampleCosineLobeV(ctx, min1(hn::Div(hn::Sub(u0, hn::Set(df, p)), hn::Set(df, 1.0f - p))), u1, cosWi, cosPdf);
  for (int c = 0; c < 3; ++c) wi[c] = hn::IfThenElse(specular, ggxWi[c], cosWi[c]);
  const VF chosen = hn::IfThenElse(specular, ggxPdf, cosPdf);
  // The density of the whole two-lobe procedure, where the chosen lobe succeeded.
  LightPathV path;
  for (int c = 0; c < 3; ++c) path.wi[c] = wi[c];
  path.cosI = Dot(ctx.sp.n, wi);
  pdf = hn::IfThenElseZero(hn::Gt(chosen, hn::Zero(df)), PdfBsdfUniformV(bsdf, ctx.sp, path));
}

// Draws [k, k + Lanes) of the uniforms (those of `valid` lanes); the ones that count are appended at `written`,
// which grows by their number. Writes Lanes entries from `written` on.
HWY_INLINE void DrawPacket(const BsdfContext& ctx, const float* u0, const float* u1, MF valid,
                           float* const (&out)[10], uint32_t* draw, uint32_t firstDraw, size_t k, size_t& written) {
  const DF df;
  const DI di;
  const VF zero = hn::Zero(df);
  VF wi[3], pdf;
  SampleBsdfV(ctx, hn::LoadU(df, u0 + k), hn::LoadU(df, u1 + k), wi, pdf);
  const MF counts = hn::And(valid, hn::And(hn::Gt(pdf, zero), hn::Gt(Dot(ctx.sp.ng, wi), zero)));
  // The throughput f_r cos θi / p.
  LightPathV path;
  for (int c = 0; c < 3; ++c) path.wi[c] = wi[c];
  path.cosI = Dot(ctx.sp.n, wi);
  VF f[3];
  EvalBsdfV(ctx.sp, path, counts, f);
  const VF scale = hn::Div(path.cosI, pdf);
  VF org[3];
  OffsetRayOriginV(ctx.sp.x, ctx.sp.ng, ctx.errorScale, wi, org);
  const VI source = hn::Compress(hn::Iota(di, 0), hn::RebindMask(di, counts));
  const auto pack = hn::IndicesFromVec(df, source);
  for (int c = 0; c < 3; ++c) {
    hn::StoreU(hn::TableLookupLanes(CanonicalNaNV(org[c]), pack), df, out[c] + written);
    hn::StoreU(hn::TableLookupLanes(CanonicalNaNV(wi[c]), pack), df, out[3 + c] + written);
    hn::StoreU(hn::TableLookupLanes(CanonicalNaNV(hn::Mul(f[c], scale)), pack), df, out[6 + c] + written);
  }
  hn::StoreU(hn::TableLookupLanes(CanonicalNaNV(pdf), pack), df, out[9] + written);
  const hn::RebindToUnsigned<DI> du;
  hn::StoreU(hn::Add(hn::BitCast(du, source), hn::Set(du, static_cast<uint32_t>(k) + firstDraw)), du, draw + written);
  written += hn::CountTrue(df, counts);
}

size_t BsdfDrawKernel(const LightDrawReceiver& r, const BsdfSoa& materials, const BsdfDraws& draws,
                      const BsdfDrawOutputs& out) {
  const DF df;
  const size_t N = hn::Lanes(df);
  BsdfContext ctx;
  ctx.bsdf = materials.At(static_cast<size_t>(r.materialId));
  ctx.sp = BroadcastShadingPointV(r.position, r.geometricNormal, r.shadingNormal, r.wo, ctx.bsdf);
  Vec3 t, b;
  OrthonormalBasis(r.shadingNormal, t, b);
  for (int c = 0; c < 3; ++c) {
    ctx.t[c] = hn::Set(df, t[c]);
    ctx.b[c] = hn::Set(df, b[c]);
  }
  ctx.errorScale = hn::Set(df, r.errorScale);

  float* const o[10] = {out.org[0],    out.org[1],    out.org[2],    out.dir[0],    out.dir[1],
                        out.dir[2],    out.weight[0], out.weight[1], out.weight[2], out.pdf};
  size_t k = 0, written = 0;
  for (; k + N <= draws.count; k += N)
    DrawPacket(ctx, draws.u0, draws.u1, hn::FirstN(df, N), o, out.draw, out.firstDraw, k, written);
  if (k == draws.count) return written;
  // Tail: one packet on padded copies, its lanes past the end masked off.
  constexpr size_t kMax = hn::MaxLanes(DF());
  const size_t rest = draws.count - k;
  HWY_ALIGN float u[2][kMax] = {};
  for (size_t l = 0; l < rest; ++l) {
    u[0][l] = draws.u0[k + l];
    u[1][l] = draws.u1[k + l];
  }
  HWY_ALIGN float padded[10][kMax];
  HWY_ALIGN uint32_t index[kMax];
  float* const p[10] = {padded[0], padded[1], padded[2], padded[3], padded[4],
                        padded[5], padded[6], padded[7], padded[8], padded[9]};
  size_t kept = 0;
  DrawPacket(ctx, u[0], u[1], hn::FirstN(df, rest), p, index, 0, 0, kept);
  for (size_t l = 0; l < kept; ++l) {
    for (int f = 0; f < 10; ++f) o[f][written + l] = padded[f][l];
    out.draw[written + l] = index[l] + static_cast<uint32_t>(k) + out.firstDraw;
  }
  return written + kept;
}

const char* BsdfDrawKernelTargetName() {
  return hwy::TargetName(HWY_TARGET);
}

}  // namespace
// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#if HWY_ONCE

namespace restir {

HWY_EXPORT(BsdfDrawKernel);
HWY_EXPORT(BsdfDrawKernelTargetName);

size_t DrawBsdfSamplesScalar(const LightDrawReceiver& r, const BsdfSoa& materials, const BsdfDraws& draws,
                             const BsdfDrawOutputs& out) {
  const Bsdf bsdf = materials.At(static_cast<size_t>(r.materialId));
  size_t written = 0;
  for (size_t k = 0; k < draws.count; ++k) {
    const BsdfSample bs = SampleBsdf(bsdf, r.shadingNormal, r.wo, draws.u0[k], draws.u1[k]);
    if (!(bs.pdf > 0.0f && glm::dot(r.geometricNormal, bs.wi) > 0.0f)) continue;
    const Vec3 f = EvalBsdf(bsdf, r.shadingNormal, r.wo, bs.wi);
    const Vec3 weight = f * (glm::dot(r.shadingNormal, bs.wi) / bs.pdf);
    const Vec3 org = OffsetRayOrigin(r.position, r.geometricNormal, r.errorScale, bs.wi);
    for (int c = 0; c < 3; ++c) {
      out.org[c][written] = CanonicalNaN(org[c]);
      out.dir[c][written] = CanonicalNaN(bs.wi[c]);
      out.weight[c][written] = CanonicalNaN(weight[c]);
    }
    out.pdf[written] = CanonicalNaN(bs.pdf);
    out.draw[written] = static_cast<uint32_t>(k) + out.firstDraw;
    ++written;
  }
  return written;
}

size_t DrawBsdfSamples(const LightDrawReceiver& receiver, const BsdfSoa& materials, const BsdfDraws& draws,
                       const BsdfDrawOutputs& out) {
  if (UseScalarTwins()) return DrawBsdfSamplesScalar(receiver, materials, draws, out);
  return HWY_DYNAMIC_DISPATCH(BsdfDrawKernel)(receiver, materials, draws, out);
}

const char* BsdfDrawKernelDispatchedTargetName() {
  if (UseScalarTwins()) return "scalar";
  return HWY_DYNAMIC_DISPATCH(BsdfDrawKernelTargetName)();
}

}  // namespace restir

#endif  // HWY_ONCE
