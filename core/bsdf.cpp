#include "core/bsdf.h"

#include <algorithm>

#include "core/sampling.h"

namespace restir {

namespace {

Vec3 SchlickFresnel(const Vec3& f0, float cosTheta) {
  const float m = 1.0f - std::min(1.0f, std::max(0.0f, cosTheta));
  const float m5 = (m * m) * (m * m) * m;
  return f0 + (Vec3(1.0f) - f0) * m5;
}

Vec3 ToWorld(const Vec3& n, const Vec3& local) {
  Vec3 t, b;
  OrthonormalBasis(n, t, b);
  return local.x * t + local.y * b + local.z * n;
}

// The GGX microfacet lobe D G2 F / (4 cosO cosI) with Schlick Fresnel of normal-incidence reflectance f0
// (Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces", Eq. 20), for cosO = n.wo > 0
// and cosI = n.wi > 0 (the caller's hemisphere test): the one form of the equation kGgx (f0 = albedo) and
// kLayered (f0 = specular) share. Returns false, leaving `value` unset, where the half vector is undefined
// (!(|wo + wi| > 0)).
bool GgxLobe(const Vec3& f0, float alpha, const Vec3& n, const Vec3& wo, const Vec3& wi, float cosO, float cosI,
             Vec3& value) {
  const Vec3 hSum = wo + wi;
  const float hLen = glm::length(hSum);
  if (!(hLen > 0.0f)) return false;
  const Vec3 h = hSum / hLen;
  const float d = GgxD(glm::dot(n, h), alpha);
  // Height-correlated Smith masking-shadowing (Heitz 2014, Eq. 99).
  const float g = 1.0f / (1.0f + GgxLambda(cosO, alpha) + GgxLambda(cosI, alpha));
  const Vec3 f = SchlickFresnel(f0, glm::dot(wi, h));
  value = f * (d * g / (4.0f * cosO * cosI));
  return true;
}

// Cosine-weighted hemisphere by Malley's method: a uniform disk point lifted onto the hemisphere. pdf cos/pi.
BsdfSample SampleCosineLobe(const Vec3& n, float u0, float u1) {
  BsdfSample s;
  const float r = std::sqrt(u0);
  float sinPhi, cosPhi;
  SinCos2Pi(u1, sinPhi, cosPhi);
  const Vec3 local(r * cosPhi, r * sinPhi, std::sqrt(std::max(0.0f, 1.0f - u0)));
  s.wi = ToWorld(n, local);
  s.pdf = local.z * kInvPi;
  return s;
}

// GGX: tan^2(theta_h) = alpha^2 u0 / (1 - u0) inverts the CDF of D(h) cos(theta_h) (Walter et al. 2007, Eq. 35
// and 36), then wi = reflect(wo, h). pdf D(h) cos(theta_h) / (4 wo.h), the half-vector density times the
// reflection Jacobian (ibid. Eq. 14); 0 (failure) when wo faces away from h or wi falls below the horizon.
BsdfSample SampleGgxLobe(float alpha, const Vec3& n, const Vec3& wo, float u0, float u1) {
  BsdfSample s;
  const float a2 = alpha * alpha;
  const float cos2 = (1.0f - u0) / (1.0f + (a2 - 1.0f) * u0);
  const float cosH = std::sqrt(std::max(0.0f, cos2));
  const float sinH = std::sqrt(std::max(0.0f, 1.0f - cos2));
  float sinPhi, cosPhi;
  SinCos2Pi(u1, sinPhi, cosPhi);
  const Vec3 h = ToWorld(n, Vec3(sinH * cosPhi, sinH * sinPhi, cosH));
  const float oh = glm::dot(wo, h);
  if (oh <= 0.0f) return s;
  s.wi = 2.0f * oh * h - wo;
  if (glm::dot(n, s.wi) <= 0.0f) return s;
  s.pdf = GgxD(cosH, alpha) * cosH / (4.0f * oh);
  return s;
}

// SampleGgxLobe's density at wi, for wi and wo above the horizon (the caller's test).
float PdfGgxLobe(float alpha, const Vec3& n, const Vec3& wo, const Vec3& wi) {
  const Vec3 hSum = wo + wi;
  const float hLen = glm::length(hSum);
  if (!(hLen > 0.0f)) return 0.0f;
  const Vec3 h = hSum / hLen;
  const float oh = glm::dot(wo, h);
  if (oh <= 0.0f) return 0.0f;
  const float cosH = glm::dot(n, h);
  return GgxD(cosH, alpha) * cosH / (4.0f * oh);
}

}  // namespace

Vec3 EvalBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, const Vec3& wi) {
  const float cosO = glm::dot(n, wo);
  const float cosI = glm::dot(n, wi);
  if (cosO <= 0.0f || cosI <= 0.0f) return Vec3(0.0f);
  if (bsdf.type == BsdfType::kDiffuse) return bsdf.albedo * kInvPi;
  Vec3 lobe;
  if (bsdf.type == BsdfType::kGgx) {
    if (!GgxLobe(bsdf.albedo, bsdf.alpha, n, wo, wi, cosO, cosI, lobe)) return Vec3(0.0f);
    return lobe;
  }
  // kLayered: (albedo * kInvPi) + (ggxLobe * specularWeight), the tree core/shading-inl.h EvalBsdfV mirrors.
  const Vec3 diffuse = bsdf.albedo * kInvPi;
  if (!GgxLobe(bsdf.specular, bsdf.alpha, n, wo, wi, cosO, cosI, lobe)) return diffuse;
  return diffuse + lobe * bsdf.specularWeight;
}

float LayeredSpecularProbability(const Bsdf& bsdf) {
  const float specular = bsdf.specularWeight * Luminance(bsdf.specular);
  const float total = specular + Luminance(bsdf.albedo);
  if (!(total > 0.0f)) return 0.0f;
  const float p = specular / total;
  if (!(p > 0.0f)) return 0.0f;  // also NaN (an infinite weight)
  return std::min(p, 1.0f);
}

BsdfSample SampleBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, float u0, float u1) {
  if (bsdf.type == BsdfType::kDiffuse) return SampleCosineLobe(n, u0, u1);
  if (bsdf.type == BsdfType::kGgx) return SampleGgxLobe(bsdf.alpha, n, wo, u0, u1);
  // kLayered: u0 < P picks the GGX lobe and u0 / P is uniform on [0, 1) given that choice; otherwise
  // (u0 - P) / (1 - P) is, for the cosine lobe. Rounding can carry either quotient to 1, hence the clamp.
  const float p = LayeredSpecularProbability(bsdf);
  BsdfSample s;
  if (u0 < p) {
    s = SampleGgxLobe(bsdf.alpha, n, wo, std::min(u0 / p, kOneMinusEpsilon), u1);
  } else {
    s = SampleCosineLobe(n, std::min((u0 - p) / (1.0f - p), kOneMinusEpsilon), u1);
  }
  if (!(s.pdf > 0.0f)) return BsdfSample{};
  // The density of the whole two-lobe procedure at wi, as PdfBsdf computes it (so the two agree bit for bit).
  s.pdf = PdfBsdf(bsdf, n, wo, s.wi);
  return s;
}

float PdfBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, const Vec3& wi) {
  const float cosI = glm::dot(n, wi);
  if (cosI <= 0.0f || glm::dot(n, wo) <= 0.0f) return 0.0f;
  if (bsdf.type == BsdfType::kDiffuse) return cosI * kInvPi;
  if (bsdf.type == BsdfType::kGgx) return PdfGgxLobe(bsdf.alpha, n, wo, wi);
  // kLayered: P pdf_GGX + (1 - P) pdf_cos. A lobe never chosen is left out rather than weighted by 0, so a
  // non-finite density of the other lobe (alpha = 0 at the mirror direction) cannot turn the sum into NaN.
  const float p = LayeredSpecularProbability(bsdf);
  const float pdfCos = cosI * kInvPi;
  if (p == 0.0f) return pdfCos;
  const float pdfGgx = PdfGgxLobe(bsdf.alpha, n, wo, wi);
  if (p == 1.0f) return pdfGgx;
  return p * pdfGgx + (1.0f - p) * pdfCos;
}

BsdfSoa MakeBsdfSoa(const std::vector<Bsdf>& bsdfs) {
  BsdfSoa m;
  for (const Bsdf& b : bsdfs) {
    m.type.push_back(static_cast<int32_t>(b.type));
    for (int c = 0; c < 3; ++c) m.albedo[c].push_back(b.albedo[c]);
    m.alpha.push_back(b.alpha);
    for (int c = 0; c < 3; ++c) m.specular[c].push_back(b.specular[c]);
    m.specularWeight.push_back(b.specularWeight);
  }
  return m;
}

}  // namespace restir
