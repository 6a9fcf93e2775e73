#include "core/bsdf.h"

#include <gtest/gtest.h>

#include "core/rng.h"
#include "stats.h"

namespace restir {
namespace {

Vec3 UniformHemisphere(float u0, float u1) {
  const float z = u0, r = std::sqrt(std::max(0.0f, 1 - z * z)), phi = 2 * kPi * u1;
  return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

const Vec3 kN(0, 0, 1);

TEST(Bsdf, DiffuseIsAlbedoOverPi) {
  Bsdf b{BsdfType::kDiffuse, Vec3(0.5f, 0.25f, 1.0f), 0};
  const Vec3 f = EvalBsdf(b, kN, glm::normalize(Vec3(0.3f, 0.1f, 1)), glm::normalize(Vec3(-1, 0.2f, 0.5f)));
  EXPECT_FLOAT_EQ(f.x, 0.5f / kPi);
  EXPECT_FLOAT_EQ(f.z, 1.0f / kPi);
  EXPECT_EQ(EvalBsdf(b, kN, Vec3(0, 0, 1), Vec3(1, 0, -0.1f)).x, 0.0f);
}

TEST(Bsdf, GgxIsReciprocal) {
  Bsdf b{BsdfType::kGgx, Vec3(0.9f, 0.6f, 0.3f), 0.2f};
  for (int i = 0; i < 1000; ++i) {
    Sampler s(RngKey{1, 0, static_cast<uint32_t>(i), 100});
    const Vec3 wo = UniformHemisphere(s.Next(), s.Next()), wi = UniformHemisphere(s.Next(), s.Next());
    const Vec3 a = EvalBsdf(b, kN, wo, wi), c = EvalBsdf(b, kN, wi, wo);
    EXPECT_NEAR(a.x, c.x, 1e-4f * (1 + a.x));
  }
}

// The sampled direction's reported pdf equals PdfBsdf at that direction (both models).
TEST(Bsdf, SamplePdfMatchesPdfFunction) {
  for (auto type : {BsdfType::kDiffuse, BsdfType::kGgx}) {
    Bsdf b{type, Vec3(0.7f), 0.09f};
    for (int i = 0; i < 2000; ++i) {
      Sampler s(RngKey{2, 0, static_cast<uint32_t>(i), 100});
      const Vec3 wo = UniformHemisphere(s.Next(), s.Next());
      const BsdfSample bs = SampleBsdf(b, kN, wo, s.Next(), s.Next());
      if (bs.pdf <= 0) continue;
      EXPECT_NEAR(bs.pdf, PdfBsdf(b, kN, wo, bs.wi), 1e-3f * bs.pdf);
    }
  }
}

// Sampling density integrates over the hemisphere to the probability that sampling succeeds: 1 for diffuse,
// the fraction of GGX samples not reflected below the horizon. Uniform-hemisphere estimate of ∫ pdf dω against
// the counted success fraction, Welch z-test with false-failure rate 1e-6.
TEST(Bsdf, PdfIntegratesToAtMostOne) {
  const double z = test::NormalQuantileUpper(1e-6);
  for (float alpha : {0.05f, 0.3f, 0.8f}) {
    for (auto type : {BsdfType::kDiffuse, BsdfType::kGgx}) {
      Bsdf b{type, Vec3(1.0f), alpha};
      const Vec3 wo = glm::normalize(Vec3(0.4f, 0.0f, 1.0f));
      test::RunningStats st, success;
      for (int i = 0; i < 400000; ++i) {
        Sampler s(RngKey{3, 0, static_cast<uint32_t>(i), 100});
        st.Add(PdfBsdf(b, kN, wo, UniformHemisphere(s.Next(), s.Next())) * 2 * kPi);
        success.Add(SampleBsdf(b, kN, wo, s.Next(), s.Next()).pdf > 0 ? 1.0 : 0.0);
      }
      const double se = std::sqrt(st.StdError() * st.StdError() + success.StdError() * success.StdError());
      EXPECT_NEAR(st.mean, success.mean, z * se) << alpha;
      if (type == BsdfType::kDiffuse) {
        EXPECT_EQ(success.mean, 1.0);
      }
    }
  }
}

// Importance-sampled and uniformly sampled estimates of the directional albedo ∫ f cos dω agree (Welch z-test,
// false-failure rate 1e-6), and the albedo of a white GGX reflector is at most 1.
TEST(Bsdf, GgxImportanceSamplingIsUnbiased) {
  const double z = test::NormalQuantileUpper(1e-6);
  for (float alpha : {0.1f, 0.4f}) {
    Bsdf b{BsdfType::kGgx, Vec3(1.0f), alpha};
    const Vec3 wo = glm::normalize(Vec3(0.5f, 0.2f, 1.0f));
    test::RunningStats is, un;
    for (int i = 0; i < 400000; ++i) {
      Sampler s(RngKey{4, 0, static_cast<uint32_t>(i), 100});
      const BsdfSample bs = SampleBsdf(b, kN, wo, s.Next(), s.Next());
      is.Add(bs.pdf > 0 ? EvalBsdf(b, kN, wo, bs.wi).x * bs.wi.z / bs.pdf : 0.0);
      const Vec3 wu = UniformHemisphere(s.Next(), s.Next());
      un.Add(EvalBsdf(b, kN, wo, wu).x * wu.z * 2 * kPi);
    }
    const double se = std::sqrt(is.StdError() * is.StdError() + un.StdError() * un.StdError());
    EXPECT_NEAR(is.mean, un.mean, z * se) << alpha;
    EXPECT_LE(is.mean, 1.0 + z * is.StdError());
    EXPECT_GT(is.mean, 0.7);  // single-scattering GGX loses energy with roughness, never most of it
  }
}

}  // namespace
}  // namespace restir
