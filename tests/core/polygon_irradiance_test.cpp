#include "core/polygon_irradiance.h"

#include <gtest/gtest.h>

namespace restir {
namespace {

// Irradiance under a rectangle parallel to the receiver with one corner straight above it: the classical
// form factor F = 1/(2π) [a/√(1+a²) atan(b/√(1+a²)) + b/√(1+b²) atan(a/√(1+b²))], E = π L F.
TEST(PolygonIrradiance, MatchesCornerRectangleFormFactor) {
  for (double X : {0.5, 1.0, 3.0}) {
    for (double Y : {0.25, 2.0}) {
      const double d = 1.5, a = X / d, b = Y / d;
      const double f = (a / std::sqrt(1 + a * a) * std::atan(b / std::sqrt(1 + a * a)) +
                        b / std::sqrt(1 + b * b) * std::atan(a / std::sqrt(1 + b * b))) /
                       (2 * M_PI);
      const std::vector<Vec3> quad{Vec3(0, 0, d), Vec3(X, 0, d), Vec3(X, Y, d), Vec3(0, Y, d)};
      EXPECT_NEAR(PolygonIrradiance(Vec3(0), Vec3(0, 0, 1), quad, 2.0), M_PI * 2.0 * f, 1e-5);
    }
  }
}

// A small distant patch behaves like a point: E ≈ L A cosθ_x cosθ_y / d².
TEST(PolygonIrradiance, SmallPatchIsInverseSquare) {
  const float s = 0.001f;
  const Vec3 c(0.3f, 0.0f, 2.0f);
  const std::vector<Vec3> quad{c + Vec3(-s, -s, 0), c + Vec3(s, -s, 0), c + Vec3(s, s, 0), c + Vec3(-s, s, 0)};
  const double d2 = glm::dot(c, c), cosT = c.z / std::sqrt(d2);
  const double expected = 1.0 * (4 * s * s) * cosT * cosT / d2;
  EXPECT_NEAR(PolygonIrradiance(Vec3(0), Vec3(0, 0, 1), quad, 1.0), expected, 1e-3 * expected);
}

TEST(PolygonIrradiance, OrientationDoesNotMatter) {
  const std::vector<Vec3> a{Vec3(0, 0, 1), Vec3(1, 0, 1), Vec3(0, 1, 1)};
  const std::vector<Vec3> b{Vec3(0, 0, 1), Vec3(0, 1, 1), Vec3(1, 0, 1)};
  EXPECT_DOUBLE_EQ(PolygonIrradiance(Vec3(0), Vec3(0, 0, 1), a, 1.0),
                   PolygonIrradiance(Vec3(0), Vec3(0, 0, 1), b, 1.0));
}

}  // namespace
}  // namespace restir

namespace restir {
namespace {

// A square straddling the horizon: the clipped part's irradiance equals that of the half above the plane.
TEST(PolygonIrradiance, ClippingKeepsOnlyTheUpperHemisphere) {
  const std::vector<Vec3> square{Vec3(-1, -1, 2), Vec3(1, -1, 2), Vec3(1, 1, 2), Vec3(-1, 1, 2)};
  // Receiver normal +y: only the y >= 0 half of the square is above the horizon.
  const std::vector<Vec3> clipped = ClipPolygonToHemisphere(Vec3(0), Vec3(0, 1, 0), square);
  const std::vector<Vec3> upperHalf{Vec3(-1, 0, 2), Vec3(1, 0, 2), Vec3(1, 1, 2), Vec3(-1, 1, 2)};
  EXPECT_NEAR(PolygonIrradiance(Vec3(0), Vec3(0, 1, 0), clipped, 1.0),
              PolygonIrradiance(Vec3(0), Vec3(0, 1, 0), upperHalf, 1.0), 1e-6);
  EXPECT_TRUE(ClipPolygonToHemisphere(Vec3(0), Vec3(0, 0, -1), square).empty());
}

}  // namespace
}  // namespace restir
