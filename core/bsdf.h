// Reflectance models the scenes need (DESIGN §8): Lambertian diffuse, a GGX microfacet reflector with Schlick
// Fresnel, and a diffuse + GGX layered model. Directions are unit vectors pointing away from the surface; n is the
// shading normal.
//
// kLayered is the model sim/ maps glTF metallic-roughness and MTL Kd/Ks materials onto:
//   f_r(wo, wi) = albedo / pi + specularWeight * GGX_Schlick(wo, wi; F0 = specular, alpha),
// where GGX_Schlick is exactly the kGgx lobe (GgxD, height-correlated Smith G2, Schlick Fresnel with F0 =
// `specular`). It is a convex mixture of two lobes that never gain energy: sim/ sets albedo = (1 - s) baseColor,
// specularWeight = s and specular = F0' with s in [0, 1] and F0' in [0, 1]^3. The Lambertian term's directional
// albedo is (1 - s) baseColor. Single-scattering GGX with Fresnel F <= 1 reflects at most 1: its directional albedo
// is the integral of F G2(wo, wi) / G1(wo) over the distribution of visible normals D_wo, which integrates to 1
// (Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs"), and G2 <= G1. So the
// directional albedo of the sum is at most (1 - s) max(baseColor) + s * 1 <= 1. The lobes are simply added, with
// no Fresnel-dependent attenuation of the diffuse layer (as glTF's reference BRDF or pbrt-v4's layered BxDFs
// model): the convex weights already keep the sum below 1, and the sum stays reciprocal.
#pragma once

#include <cstdint>
#include <vector>

#include "core/math.h"

namespace restir {

enum class BsdfType : uint8_t { kDiffuse, kGgx, kLayered };

// Fields after `alpha` are read by kLayered only, and default so that the aggregate form Bsdf{type, albedo, alpha}
// describes a diffuse or GGX material completely.
struct Bsdf {
  BsdfType type = BsdfType::kDiffuse;  // closed set of models
  Vec3 albedo{0.8f};                   // diffuse reflectance, or GGX normal-incidence Fresnel F0; for kLayered
                                       // the diffuse reflectance, already weighted ((1 - s) baseColor)
  float alpha = 0.25f;                 // GGX width alpha = roughness^2 (ignored for diffuse)
  Vec3 specular{0.0f};                 // kLayered: F0 of the GGX lobe
  float specularWeight = 0.0f;         // kLayered: weight s of the GGX lobe
};

struct BsdfSample {
  Vec3 wi;          // sampled incident direction
  float pdf = 0.0f; // solid-angle density of wi; 0 when the sample failed
};

// GGX (Trowbridge-Reitz) normal distribution D(h) for cos(theta_h) = n.h.
inline float GgxD(float cosThetaH, float alpha) {
  if (cosThetaH <= 0.0f) return 0.0f;
  const float a2 = alpha * alpha;
  const float c2 = cosThetaH * cosThetaH;
  const float denom = c2 * (a2 - 1.0f) + 1.0f;
  return a2 / (kPi * denom * denom);
}

// Smith Lambda for GGX: G1 = 1 / (1 + Lambda).
inline float GgxLambda(float cosTheta, float alpha) {
  const float c2 = cosTheta * cosTheta;
  if (c2 <= 0.0f) return 0.0f;
  const float tan2 = (1.0f - c2) / c2;
  return 0.5f * (std::sqrt(1.0f + alpha * alpha * tan2) - 1.0f);
}

// f_r(wo, wi), without the cosine; 0 when either direction is below the shading hemisphere. For kLayered the
// float expression is, per channel, (albedo * kInvPi) + (ggxLobe * specularWeight) with ggxLobe the kGgx value
// for F0 = specular (the SIMD kernels, core/shading-inl.h, compute the same tree); where the half vector is
// undefined (!(|wo + wi| > 0), reachable only with non-finite input) the GGX lobe is absent and the value is the
// diffuse term alone.
Vec3 EvalBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, const Vec3& wi);

// The probability with which SampleBsdf draws kLayered's GGX lobe rather than its cosine lobe: the lobes'
// luminance weights, P = s Y(specular) / (s Y(specular) + Y(albedo)) (Y = Luminance), a cheap stand-in for their
// directional albedos. Any P gives an unbiased estimator, since SampleBsdf reports the whole mixture's pdf; this
// one only sets the variance. 0 when the denominator is not > 0 or the quotient is NaN; clamped to [0, 1] for
// out-of-range (negative) inputs.
float LayeredSpecularProbability(const Bsdf& bsdf);

// Draws wi: cosine-weighted for diffuse, D(h)·cos(theta_h) half-vectors for GGX; for kLayered one of the two
// lobes, the GGX one with probability P = LayeredSpecularProbability, reusing u0 (rescaled into [0, 1) within
// the chosen lobe's share). The returned pdf is the density of the whole procedure: for kLayered the mixture
// P pdf_GGX + (1 - P) pdf_cos, exactly PdfBsdf at the sampled wi (one-sample MIS with the balance heuristic, Veach
// 1997 §9.2.4). A failed sample (reflected below the horizon) has pdf 0.
BsdfSample SampleBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, float u0, float u1);

// Solid-angle density of SampleBsdf producing wi.
float PdfBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, const Vec3& wi);

// The BSDFs of a frame's materials as structure-of-arrays, the table every SIMD kernel gathers from (built once
// per frame, see MakeBsdfSoa).
struct BsdfSoa {
  std::vector<int32_t> type;          // static_cast<int32_t>(BsdfType)
  std::vector<float> albedo[3];       // Bsdf::albedo r g b
  std::vector<float> alpha;           // Bsdf::alpha
  std::vector<float> specular[3];     // Bsdf::specular r g b
  std::vector<float> specularWeight;  // Bsdf::specularWeight
  size_t Size() const { return type.size(); }
  // The Bsdf of entry m, as the scalar twins read it.
  Bsdf At(size_t m) const {
    return Bsdf{static_cast<BsdfType>(type[m]), Vec3(albedo[0][m], albedo[1][m], albedo[2][m]), alpha[m],
                Vec3(specular[0][m], specular[1][m], specular[2][m]), specularWeight[m]};
  }
};
BsdfSoa MakeBsdfSoa(const std::vector<Bsdf>& bsdfs);

}  // namespace restir
