// Reflectance models the scenes need (DESIGN §8): Lambertian diffuse and a GGX microfacet reflector with
// Schlick Fresnel. Directions are unit vectors pointing away from the surface; n is the shading normal.
#pragma once

#include <cstdint>
#include <vector>

#include "core/math.h"

namespace restir {

enum class BsdfType : uint8_t { kDiffuse, kGgx };

struct Bsdf {
  BsdfType type = BsdfType::kDiffuse;  // closed set of models
  Vec3 albedo{0.8f};                   // diffuse reflectance, or GGX normal-incidence Fresnel F0
  float alpha = 0.25f;                 // GGX width alpha = roughness^2 (ignored for diffuse)
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

// f_r(wo, wi), without the cosine; 0 when either direction is below the shading hemisphere.
Vec3 EvalBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, const Vec3& wi);

// Draws wi: cosine-weighted for diffuse, D(h)·cos(theta_h) half-vectors for GGX.
BsdfSample SampleBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, float u0, float u1);

// Solid-angle density of SampleBsdf producing wi.
float PdfBsdf(const Bsdf& bsdf, const Vec3& n, const Vec3& wo, const Vec3& wi);

// The BSDFs of a frame's materials as structure-of-arrays, the table every SIMD kernel gathers from (built once
// per frame, see MakeBsdfSoa).
struct BsdfSoa {
  std::vector<int32_t> type;      // static_cast<int32_t>(BsdfType)
  std::vector<float> albedo[3];   // Bsdf::albedo r g b
  std::vector<float> alpha;       // Bsdf::alpha
  size_t Size() const { return type.size(); }
  // The Bsdf of entry m, as the scalar twins read it.
  Bsdf At(size_t m) const {
    return Bsdf{static_cast<BsdfType>(type[m]), Vec3(albedo[0][m], albedo[1][m], albedo[2][m]), alpha[m]};
  }
};
BsdfSoa MakeBsdfSoa(const std::vector<Bsdf>& bsdfs);

}  // namespace restir
