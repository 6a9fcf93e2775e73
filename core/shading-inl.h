// Per-target Highway versions of the shading equations (core/shading.h ConnectToLight, UnshadowedContribution,
// TargetFunction; core/bsdf.cpp EvalBsdf), shared by the SIMD kernels (core/ris_kernel.cpp,
// core/target_kernel.cpp) so that each equation has one SIMD form, next to its one scalar form.
//
// Include after "hwy/foreach_target.h" and "hwy/highway.h", outside any namespace: like every Highway -inl
// header it is compiled once per target and opens restir::HWY_NAMESPACE itself.
//
// Bit-exactness (DESIGN §3): each lane computes exactly the scalar expression tree, term for term in the same
// order: glm::dot(a, b) = (a.x b.x + a.y b.y) + a.z b.z, glm::length = sqrt(dot), vec3 / s divides each
// component. Branches of the scalar code become masks; every early return is mirrored with the scalar test
// itself (e.g. !(c <= 0), which differs from c > 0 for NaN) and every BSDF model is evaluated then selected, so a
// value computed on a path the scalar code would not take never reaches a result. No MulAdd (FMA), no
// approximate reciprocals or square roots.

#include "core/bsdf.h"
#include "core/kernel-inl.h"
#include "core/bsdf.h"  // BsdfSoa
#include "core/shading.h"

// Highway's per-target include guard: the body is compiled once for each target foreach_target.h toggles.
#if defined(RESTIR_CORE_SHADING_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef RESTIR_CORE_SHADING_INL_H_
#undef RESTIR_CORE_SHADING_INL_H_
#else
#define RESTIR_CORE_SHADING_INL_H_
#endif

#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {
// DF, DI, VF, VI, MF and hn come from core/kernel-inl.h.

HWY_INLINE VF Dot(VF ax, VF ay, VF az, VF bx, VF by, VF bz) {
  return hn::Add(hn::Add(hn::Mul(ax, bx), hn::Mul(ay, by)), hn::Mul(az, bz));
}
HWY_INLINE VF Dot(const VF (&a)[3], const VF (&b)[3]) { return Dot(a[0], a[1], a[2], b[0], b[1], b[2]); }

// !(a <= b): the negation of the scalar code's early-return test (true for NaN, unlike a > b).
HWY_INLINE MF NotLe(VF a, VF b) { return hn::Not(hn::Le(a, b)); }

// glm::normalize(v) in GLM's non-SIMD path (glm/detail/func_geometric.inl compute_normalize): v * inversesqrt
// (dot(v, v)), with inversesqrt(x) = 1 / sqrt(x) (func_exponential.inl). One division, then three products:
// not the same bits as v / length(v).
HWY_INLINE void NormalizeV(const VF (&v)[3], VF (&out)[3]) {
  const VF inv = hn::Div(hn::Set(DF(), 1.0f), hn::Sqrt(Dot(v, v)));
  for (int c = 0; c < 3; ++c) out[c] = hn::Mul(v[c], inv);
}

// GgxLambda (core/bsdf.h): 0 when c^2 <= 0, else 0.5 (sqrt(1 + alpha alpha tan2) - 1), tan2 = (1 - c^2) / c^2.
HWY_INLINE VF GgxLambdaV(VF c, VF alpha2) {
  const DF df;
  const VF one = hn::Set(df, 1.0f);
  const VF c2 = hn::Mul(c, c);
  const VF tan2 = hn::Div(hn::Sub(one, c2), c2);
  const VF v = hn::Mul(hn::Set(df, 0.5f), hn::Sub(hn::Sqrt(hn::Add(one, hn::Mul(alpha2, tan2))), one));
  return hn::IfThenZeroElse(hn::Le(c2, hn::Zero(df)), v);
}

// A packet of Bsdf (core/bsdf.h), gathered from the SoA table.
struct BsdfV {
  MF isGgx;           // BsdfType::kGgx
  MF isLayered;       // BsdfType::kLayered; a lane in neither mask is diffuse
  VF albedo[3];       // Bsdf::albedo
  VF alpha2;          // Bsdf::alpha squared: the only form of alpha the equations use
  VF specular[3];     // Bsdf::specular; zero in a packet without a layered lane, where no result reads it
  VF specularWeight;  // Bsdf::specularWeight; likewise
};

// Every lane's `materialId` must index `mt` (callers substitute a valid id in lanes they ignore).
HWY_INLINE BsdfV GatherBsdfV(const BsdfSoa& mt, VI materialId) {
  const DF df;
  const DI di;
  BsdfV b;
  const VI type = hn::GatherIndex(di, mt.type.data(), materialId);
  b.isGgx = hn::RebindMask(df, hn::Eq(type, hn::Set(di, static_cast<int32_t>(BsdfType::kGgx))));
  b.isLayered = hn::RebindMask(df, hn::Eq(type, hn::Set(di, static_cast<int32_t>(BsdfType::kLayered))));
  for (int c = 0; c < 3; ++c) b.albedo[c] = hn::GatherIndex(df, mt.albedo[c].data(), materialId);
  const VF alpha = hn::GatherIndex(df, mt.alpha.data(), materialId);
  b.alpha2 = hn::Mul(alpha, alpha);
  // The layered fields only reach lanes that are kLayered: a packet without one skips their four gathers.
  if (hn::AllFalse(df, b.isLayered)) {
    for (int c = 0; c < 3; ++c) b.specular[c] = hn::Zero(df);
    b.specularWeight = hn::Zero(df);
  } else {
    for (int c = 0; c < 3; ++c) b.specular[c] = hn::GatherIndex(df, mt.specular[c].data(), materialId);
    b.specularWeight = hn::GatherIndex(df, mt.specularWeight.data(), materialId);
  }
  return b;
}

// One Bsdf in every lane: what GatherBsdfV gives where every lane reads the same entry, without the gathers.
HWY_INLINE BsdfV BroadcastBsdfV(const Bsdf& bsdf) {
  const DF df;
  BsdfV b;
  b.isGgx = hn::RebindMask(df, hn::Eq(hn::Set(DI(), static_cast<int32_t>(bsdf.type)),
                                      hn::Set(DI(), static_cast<int32_t>(BsdfType::kGgx))));
  b.isLayered = hn::RebindMask(df, hn::Eq(hn::Set(DI(), static_cast<int32_t>(bsdf.type)),
                                          hn::Set(DI(), static_cast<int32_t>(BsdfType::kLayered))));
  for (int c = 0; c < 3; ++c) b.albedo[c] = hn::Set(df, bsdf.albedo[c]);
  const VF alpha = hn::Set(df, bsdf.alpha);
  b.alpha2 = hn::Mul(alpha, alpha);
  const bool layered = bsdf.type == BsdfType::kLayered;
  for (int c = 0; c < 3; ++c) b.specular[c] = layered ? hn::Set(df, bsdf.specular[c]) : hn::Zero(df);
  b.specularWeight = layered ? hn::Set(df, bsdf.specularWeight) : hn::Zero(df);
  return b;
}

// A packet of ShadingPoint (core/shading.h) with the parts of EvalBsdf that depend on the receiver alone, so a
// kernel that evaluates many light points per receiver computes them once.
struct ShadingPointV {
  VF x[3];        // position
  VF ng[3];       // geometric normal
  VF n[3];        // shading normal
  VF wo[3];       // towards the viewer
  BsdfV bsdf;
  VF cosO;        // dot(n, wo)
  MF cosOk;       // EvalBsdf's !(cosO <= 0)
  VF diffuse[3];  // albedo / pi: the kDiffuse value and kLayered's diffuse term
  VF lambdaO;     // GgxLambda(cosO, alpha)
};

HWY_INLINE ShadingPointV MakeShadingPointV(const VF (&x)[3], const VF (&ng)[3], const VF (&n)[3],
                                           const VF (&wo)[3], const BsdfV& bsdf) {
  const DF df;
  ShadingPointV sp;
  for (int c = 0; c < 3; ++c) {
    sp.x[c] = x[c];
    sp.ng[c] = ng[c];
    sp.n[c] = n[c];
    sp.wo[c] = wo[c];
    sp.diffuse[c] = hn::Mul(bsdf.albedo[c], hn::Set(df, kInvPi));
  }
  sp.bsdf = bsdf;
  sp.cosO = Dot(n, wo);
  sp.cosOk = NotLe(sp.cosO, hn::Zero(df));
  sp.lambdaO = GgxLambdaV(sp.cosO, bsdf.alpha2);
  return sp;
}

// One receiver in every lane (the draw kernels sample many directions or lights at one receiver).
HWY_INLINE ShadingPointV BroadcastShadingPointV(const Vec3& x, const Vec3& ng, const Vec3& n, const Vec3& wo,
                                                const Bsdf& bsdf) {
  const DF df;
  VF xv[3], ngv[3], nv[3], wov[3];
  for (int c = 0; c < 3; ++c) {
    xv[c] = hn::Set(df, x[c]);
    ngv[c] = hn::Set(df, ng[c]);
    nv[c] = hn::Set(df, n[c]);
    wov[c] = hn::Set(df, wo[c]);
  }
  return MakeShadingPointV(xv, ngv, nv, wov, BroadcastBsdfV(bsdf));
}

// LightPath (core/shading.h) of each lane, plus whether UnshadowedContribution gets past its early zero.
struct LightPathV {
  VF wi[3];       // normalize(p_y - x) as d / distance
  VF cosI;        // dot(n, wi): ConnectToLight's cosX, EvalBsdf's cosI
  VF geometry;    // G(x, y); meaningful only where `connects`
  MF connects;    // every ConnectToLight test passed and !(G <= 0)
  VF distance;    // |p_y - x|
  VF cosY;        // -dot(n_y, wi), the emitter's cosine
};

// ConnectToLight's stages (core/shading.h): the segment, then the geometry from the emitter's cosine.
HWY_INLINE VF LightSegmentV(const ShadingPointV& sp, const VF (&y)[3], LightPathV& p) {
  VF d[3];
  for (int c = 0; c < 3; ++c) d[c] = hn::Sub(y[c], sp.x[c]);
  const VF d2 = Dot(d, d);
  const VF dist = hn::Sqrt(d2);
  for (int c = 0; c < 3; ++c) p.wi[c] = hn::Div(d[c], dist);
  p.distance = dist;
  return d2;
}
HWY_INLINE void LightGeometryV(const ShadingPointV& sp, VF d2, VF cosY, LightPathV& p) {
  const DF df;
  const VF zero = hn::Zero(df);
  p.cosI = Dot(sp.n, p.wi);
  p.cosY = cosY;
  const VF cosG = Dot(sp.ng, p.wi);
  p.geometry = hn::Div(hn::Mul(p.cosI, cosY), d2);
  // Path geometry is nonzero only past every ConnectToLight test; UnshadowedContribution then needs G > 0.
  p.connects = hn::And(hn::And(hn::And(hn::Gt(p.distance, hn::Set(df, kMinLightDistance)), NotLe(p.cosI, zero)),
                               hn::And(NotLe(cosY, zero), NotLe(cosG, zero))),
                       NotLe(p.geometry, zero));
}

// ConnectToLight (core/shading.h).
HWY_INLINE LightPathV ConnectToLightV(const ShadingPointV& sp, const VF (&y)[3], const VF (&ny)[3]) {
  LightPathV p;
  const VF d2 = LightSegmentV(sp, y, p);
  LightGeometryV(sp, d2, hn::Neg(Dot(ny, p.wi)), p);
  return p;
}

// ConnectToLightOnPlane (core/shading.h): the emitter's cosine from its plane through the vertex p0.
HWY_INLINE LightPathV ConnectToLightOnPlaneV(const ShadingPointV& sp, const VF (&y)[3], const VF (&ny)[3],
                                             const VF (&p0)[3]) {
  LightPathV p;
  const VF d2 = LightSegmentV(sp, y, p);
  VF fromVertex[3];
  for (int c = 0; c < 3; ++c) fromVertex[c] = hn::Sub(sp.x[c], p0[c]);
  LightGeometryV(sp, d2, hn::Div(Dot(ny, fromVertex), p.distance), p);
  return p;
}

// EvalBsdf (core/bsdf.cpp) into f: per lane albedo / pi (kDiffuse), the GGX lobe with F0 = albedo (kGgx), or
// (albedo / pi) + (GGX lobe with F0 = specular) * specularWeight (kLayered). The GGX lobe (GgxLobe in
// core/bsdf.cpp) is evaluated once for both models, with each lane's F0 selected, and only when some lane in
// `needed` is GGX or layered and reaches it; elsewhere its value never reaches a result, so skipping it changes no
// bits.
HWY_INLINE void EvalBsdfV(const ShadingPointV& sp, const LightPathV& path, MF needed, VF (&f)[3]) {
  const DF df;
  const VF zero = hn::Zero(df);
  const VF one = hn::Set(df, 1.0f);
  // Zero unless cos(theta_o) > 0 and cos(theta_i) > 0.
  const MF bsdfOk = hn::And(sp.cosOk, NotLe(path.cosI, zero));
  for (int c = 0; c < 3; ++c) f[c] = sp.diffuse[c];
  const MF hasLobe = hn::Or(sp.bsdf.isGgx, sp.bsdf.isLayered);
  if (!hn::AllFalse(df, hn::And(hn::And(needed, bsdfOk), hasLobe))) {
    const VF alpha2 = sp.bsdf.alpha2;
    VF hSum[3], h[3];
    for (int c = 0; c < 3; ++c) hSum[c] = hn::Add(sp.wo[c], path.wi[c]);
    const VF hLen = hn::Sqrt(Dot(hSum, hSum));
    for (int c = 0; c < 3; ++c) h[c] = hn::Div(hSum[c], hLen);
    // GgxD(dot(n, h), alpha).
    const VF cosH = Dot(sp.n, h);
    const VF c2 = hn::Mul(cosH, cosH);
    const VF denom = hn::Add(hn::Mul(c2, hn::Sub(alpha2, one)), one);
    const VF dTerm = hn::IfThenZeroElse(
        hn::Le(cosH, zero), hn::Div(alpha2, hn::Mul(hn::Mul(hn::Set(df, kPi), denom), denom)));
    // Height-correlated Smith: 1 / (1 + Lambda(cosO) + Lambda(cosI)).
    const VF g = hn::Div(one, hn::Add(hn::Add(one, sp.lambdaO), GgxLambdaV(path.cosI, alpha2)));
    // SchlickFresnel(f0, dot(wi, h)): m = 1 - min(1, max(0, c)) with std::min/std::max semantics.
    const VF cosT = Dot(path.wi, h);
    const VF clamped0 = hn::IfThenElse(hn::Lt(zero, cosT), cosT, zero);      // std::max(0, c)
    const VF clamped = hn::IfThenElse(hn::Lt(clamped0, one), clamped0, one);  // std::min(1, .)
    const VF m = hn::Sub(one, clamped);
    const VF mm = hn::Mul(m, m);
    const VF m5 = hn::Mul(hn::Mul(mm, mm), m);
    const VF scale = hn::Div(hn::Mul(dTerm, g), hn::Mul(hn::Mul(hn::Set(df, 4.0f), sp.cosO), path.cosI));
    // GgxLobe's !(hLen > 0): no lobe, so kGgx is zero and kLayered the diffuse term alone.
    const MF ggxOk = hn::Gt(hLen, zero);
    const MF layeredOk = hn::And(sp.bsdf.isLayered, ggxOk);
    for (int c = 0; c < 3; ++c) {
      const VF f0 = hn::IfThenElse(sp.bsdf.isLayered, sp.bsdf.specular[c], sp.bsdf.albedo[c]);
      const VF lobe = hn::Mul(hn::Add(f0, hn::Mul(hn::Sub(one, f0), m5)), scale);
      const VF layered = hn::Add(sp.diffuse[c], hn::Mul(lobe, sp.bsdf.specularWeight));
      f[c] = hn::IfThenElse(sp.bsdf.isGgx, hn::IfThenElseZero(ggxOk, lobe),
                            hn::IfThenElse(layeredOk, layered, f[c]));
    }
  }
  for (int c = 0; c < 3; ++c) f[c] = hn::IfThenElseZero(bsdfOk, f[c]);
}

// UnshadowedContribution (core/shading.h): L_e f_r G, RGB; exactly +0 where !path.connects, as the scalar early
// return of Vec3(0). The BSDF is masked to zero before the product, as the scalar code multiplies its zero, so
// an infinite L_e or G gives NaN in both.
HWY_INLINE void UnshadowedContributionV(const ShadingPointV& sp, const LightPathV& path, const VF (&radiance)[3],
                                        VF (&out)[3]) {
  VF f[3];
  EvalBsdfV(sp, path, path.connects, f);
  for (int c = 0; c < 3; ++c)
    out[c] = hn::IfThenElseZero(path.connects, hn::Mul(hn::Mul(radiance[c], f[c]), path.geometry));
}

// PdfBsdf (core/bsdf.cpp) at each lane's wi for a BSDF every lane shares (`bsdf`, the receiver's, whose type and
// layered probability are then one scalar branch): 0 unless cosI > 0 and cos(theta_o) > 0; cosI / pi (kDiffuse);
// PdfGgxLobe = D(n.h) (n.h) / (4 wo.h), 0 where !(|wo + wi| > 0) or wo.h <= 0 (kGgx); for kLayered the mixture
// P pdf_GGX + (1 - P) pdf_cos with its two pure ends taken alone, as the scalar code does.
HWY_INLINE VF PdfBsdfUniformV(const Bsdf& bsdf, const ShadingPointV& sp, const LightPathV& path) {
  const DF df;
  const VF zero = hn::Zero(df);
  const MF hemisphere = hn::And(hn::Not(hn::Le(path.cosI, zero)), hn::Not(hn::Le(sp.cosO, zero)));
  const VF pdfCos = hn::Mul(path.cosI, hn::Set(df, kInvPi));
  if (bsdf.type == BsdfType::kDiffuse) return hn::IfThenElseZero(hemisphere, pdfCos);
  VF hSum[3], h[3];
  for (int c = 0; c < 3; ++c) hSum[c] = hn::Add(sp.wo[c], path.wi[c]);
  const VF hLen = hn::Sqrt(Dot(hSum, hSum));
  for (int c = 0; c < 3; ++c) h[c] = hn::Div(hSum[c], hLen);
  const VF oh = Dot(sp.wo, h);
  const VF cosH = Dot(sp.n, h);
  const VF alpha2 = sp.bsdf.alpha2;
  const VF c2 = hn::Mul(cosH, cosH);
  const VF denom = hn::Add(hn::Mul(c2, hn::Sub(alpha2, hn::Set(df, 1.0f))), hn::Set(df, 1.0f));
  const VF d = hn::IfThenZeroElse(hn::Le(cosH, zero),
                                  hn::Div(alpha2, hn::Mul(hn::Mul(hn::Set(df, kPi), denom), denom)));
  const VF lobe = hn::Div(hn::Mul(d, cosH), hn::Mul(hn::Set(df, 4.0f), oh));
  const VF pdfGgx = hn::IfThenElseZero(hn::And(hn::Gt(hLen, zero), hn::Not(hn::Le(oh, zero))), lobe);
  if (bsdf.type == BsdfType::kGgx) return hn::IfThenElseZero(hemisphere, pdfGgx);
  const float p = LayeredSpecularProbability(bsdf);
  if (p == 0.0f) return hn::IfThenElseZero(hemisphere, pdfCos);
  if (p == 1.0f) return hn::IfThenElseZero(hemisphere, pdfGgx);
  return hn::IfThenElseZero(hemisphere, hn::Add(hn::Mul(hn::Set(df, p), pdfGgx),
                                                hn::Mul(hn::Set(df, 1.0f - p), pdfCos)));
}

// PowerHeuristic (core/sampling.h): a² / (a² + b²), 0 where a² + b² is not positive.
HWY_INLINE VF PowerHeuristicV(VF a, VF b) {
  const VF a2 = hn::Mul(a, a), b2 = hn::Mul(b, b);
  const VF sum = hn::Add(a2, b2);
  return hn::IfThenElseZero(hn::Gt(sum, hn::Zero(DF())), hn::Div(a2, sum));
}

// TargetFunction (core/shading.h): Rec. 709 luminance (core/math.h Luminance).
HWY_INLINE VF LuminanceV(const VF (&c)[3]) {
  const DF df;
  return hn::Add(hn::Add(hn::Mul(hn::Set(df, 0.2126f), c[0]), hn::Mul(hn::Set(df, 0.7152f), c[1])),
                 hn::Mul(hn::Set(df, 0.0722f), c[2]));
}

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#endif  // RESTIR_CORE_SHADING_INL_H_ toggle
