#include "core/bsdf.h"

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

}  // namespace

Vec3 EvalBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, const Vec3& wi) {
  const float cosO = glm::dot(n, wo);
  const float cosI = glm::dot(n, wi);
  if (cosO <= 0.0f || cosI <= 0.0f) return Vec3(0.0f);
  if (bsdf.type == BsdfType::kDiffuse) return bsdf.albedo * kInvPi;
  const Vec3 hSum = wo + wi;
  const float hLen = glm::length(hSum);
  if (!(hLen > 0.0f)) return Vec3(0.0f);
  const Vec3 h = hSum / hLen;
  const float d = GgxD(glm::dot(n, h), bsdf.alpha);
  // Height-correlated Smith masking-shadowing (Heitz 2014, Eq. 99).
  const float g = 1.0f / (1.0f + GgxLambda(cosO, bsdf.alpha) + GgxLambda(cosI, bsdf.alpha));
  const Vec3 f = SchlickFresnel(bsdf.albedo, glm::dot(wi, h));
  return f * (d * g / (4.0f * cosO * cosI));
}

BsdfSample SampleBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, float u0, float u1) {
  BsdfSample s;
  if (bsdf.type == BsdfType::kDiffuse) {
    // Cosine-weighted hemisphere by Malley's method: a uniform disk point lifted onto the hemisphere.
    const float r = std::sqrt(u0);
    const float phi = 2.0f * kPi * u1;
    const Vec3 local(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0f, 1.0f - u0)));
    s.wi = ToWorld(n, local);
    s.pdf = local.z * kInvPi;
    return s;
  }
  // GGX: tan^2(theta_h) = alpha^2 u0 / (1 - u0) inverts the CDF of D(h) cos(theta_h).
  const float a2 = bsdf.alpha * bsdf.alpha;
  const float cos2 = (1.0f - u0) / (1.0f + (a2 - 1.0f) * u0);
  const float cosH = std::sqrt(std::max(0.0f, cos2));
  const float sinH = std::sqrt(std::max(0.0f, 1.0f - cos2));
  const float phi = 2.0f * kPi * u1;
  const Vec3 h = ToWorld(n, Vec3(sinH * std::cos(phi), sinH * std::sin(phi), cosH));
  const float oh = glm::dot(wo, h);
  if (oh <= 0.0f) return s;
  s.wi = 2.0f * oh * h - wo;
  if (glm::dot(n, s.wi) <= 0.0f) return s;
  s.pdf = GgxD(cosH, bsdf.alpha) * cosH / (4.0f * oh);
  return s;
}

float PdfBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, const Vec3& wi) {
  const float cosI = glm::dot(n, wi);
  if (cosI <= 0.0f || glm::dot(n, wo) <= 0.0f) return 0.0f;
  if (bsdf.type == BsdfType::kDiffuse) return cosI * kInvPi;
  const Vec3 hSum = wo + wi;
  const float hLen = glm::length(hSum);
  if (!(hLen > 0.0f)) return 0.0f;
  const Vec3 h = hSum / hLen;
  const float oh = glm::dot(wo, h);
  if (oh <= 0.0f) return 0.0f;
  const float cosH = glm::dot(n, h);
  return GgxD(cosH, bsdf.alpha) * cosH / (4.0f * oh);
}

BsdfSoa MakeBsdfSoa(const std::vector<Bsdf>& bsdfs) {
  BsdfSoa m;
  for (const Bsdf& b : bsdfs) {
    m.type.push_back(static_cast<int32_t>(b.type));
    for (int c = 0; c < 3; ++c) m.albedo[c].push_back(b.albedo[c]);
    m.alpha.push_back(b.alpha);
  }
  return m;
}

}  // namespace restir
