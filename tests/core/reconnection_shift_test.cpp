// The reconnection shift (core/reconnection_shift.h) on configurations of every kind (near and 1 km from the
// origin, tilted, grazing, millimetres to kilometres apart): the shift and its inverse undo each other, their
// Jacobians multiply to 1 (which any ratio g(x₁) / g(y₁) would: it checks the two directions agree, not the
// formula), the Jacobian is the ratio of the solid angles a small patch of x₂ subtends (measured by finite
// differences: this checks the formula), and a Monte Carlo estimate that reuses x₁'s samples at y₁ is unbiased
// with it and biased without it (a t-test each way, fixed seed).
#include "core/reconnection_shift.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "core/rng.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace reconnection_shift_test {

using D3 = glm::dvec3;

// A plane through `point` with unit normal `n`, and a receiver pair x₁, y₁ on its front.
struct Configuration {
  D3 point, n, x1, y1;
  const char* what;
};

D3 Unit(double a, double b, double c) {
  return glm::normalize(D3(a, b, c));
}

// Two tangents of n.
void Tangents(const D3& n, D3& t, D3& b) {
  t = glm::normalize(glm::cross(std::fabs(n.x) > 0.5 ? D3(0, 1, 0) : D3(1, 0, 0), n));
  b = glm::cross(n, t);
}

std::vector<Configuration> Configurations() {
  const D3 far = 1000.0 * Unit(0.8, 0.36, -0.48);
  std::vector<Configuration> c;
  c.push_back({D3(0.0), D3(0, 1, 0), D3(0.3, 1.0, 0.2), D3(-0.4, 1.3, 0.5), "floor, 1 m"});
  c.push_back(
      {far, Unit(0.3, 1.0, -0.2), far + D3(0.3, 1.0, 0.2), far + D3(-0.4, 1.3, 0.5), "tilted, 1 km out"});
  c.push_back({D3(0.0), D3(1, 0, 0), D3(2.0, 0.05, 0.1), D3(1.5, -0.02, 0.3), "wall seen at grazing"});
  c.push_back({D3(5.0), Unit(-1.0, 0.5, 0.5), D3(5.0) + 0.002 * Unit(-1, 0.7, 0.2),
               D3(5.0) + 0.003 * Unit(-1, 0.2, 0.6), "millimetres"});
  c.push_back({D3(0.0), D3(0, 0, 1), D3(1500.0, -700.0, 2000.0), D3(-800.0, 300.0, 2600.0), "kilometres"});
  return c;
}

// Where the ray from o along unit d meets the plane through `point` with normal n.
D3 HitPlane(const D3& point, const D3& n, const D3& o, const D3& d) {
  return o + d * (glm::dot(point - o, n) / glm::dot(d, n));
}

TEST(ReconnectionShift, ShiftAndInverseUndoEachOtherAndTheirJacobiansMultiplyToOne) {
  for (const Configuration& c : Configurations()) {
    D3 t, b;
    Tangents(c.n, t, b);
    const double scale = glm::length(c.x1 - c.point);
    for (int k = 0; k < 64; ++k) {
      // x₂: a point of the plane near the receivers' foot, in float as a path stores it.
      const double u = UniformFloat({7, 0, uint32_t(k), uint32_t(RngPass::kTest)}, 0) - 0.5;
      const double v = UniformFloat({7, 0, uint32_t(k), uint32_t(RngPass::kTest)}, 1) - 0.5;
      const Vec3 x2(c.point + scale * (u * t + v * b));
      const Vec3 n2(c.n), x1(c.x1), y1(c.y1);
      // T: x₁'s direction to x₂, shifted to y₁; T⁻¹: the ray from y₁ along it, back to x₁.
      const Vec3 wy = ReconnectionDirection(y1, x2);
      // The plane through x₂ as stored (its float rounding is not the shift's).
      const D3 x2Again = HitPlane(D3(x2), c.n, D3(y1), D3(wy));
      const Vec3 wxAgain = ReconnectionDirection(x1, Vec3(x2Again));
      const Vec3 wx = ReconnectionDirection(x1, x2);
      // The round trip moves x₂ by the float rounding of the directions and the plane's point: relative 1e-6
      // of the distances involved, at most.
      EXPECT_LT(glm::length(wxAgain - wx), 2e-5f) << c.what << " sample " << k;
      const double forward = ReconnectionJacobian(x1, y1, x2, n2),
                   back = ReconnectionJacobian(y1, x1, x2, n2);
      EXPECT_GT(forward, 0.0) << c.what;
      EXPECT_NEAR(forward * back, 1.0, 4e-6) << c.what << " sample " << k;
    }
  }
}

// The solid angle of the triangle of directions a, b, c (unit vectors): Van Oosterom and Strackee 1983.
double SolidAngle(const D3& a, const D3& b, const D3& c) {
  return 2.0 * std::fabs(std::atan2(glm::dot(a, glm::cross(b, c)),
                                    1.0 + glm::dot(a, b) + glm::dot(b, c) + glm::dot(c, a)));
}

TEST(ReconnectionShift, JacobianIsTheRatioOfTheSolidAnglesAPatchSubtends) {
  for (const Configuration& c : Configurations()) {
    D3 t, b;
    Tangents(c.n, t, b);
    const D3 x2 = c.point + 0.1 * glm::length(c.x1 - c.point) * (0.3 * t - 0.2 * b);
    const double h = 1e-4 * glm::length(c.x1 - x2);  // a patch small against both distances
    const D3 p0 = x2, p1 = x2 + h * t, p2 = x2 + h * b;
    const auto subtended = [&](const D3& o) {
      return SolidAngle(glm::normalize(p0 - o), glm::normalize(p1 - o), glm::normalize(p2 - o));
    };
    const double measured = subtended(c.y1) / subtended(c.x1);
    const double j = ReconnectionJacobian(Vec3(c.x1), Vec3(c.y1), Vec3(x2), Vec3(c.n));
    EXPECT_NEAR(j / measured, 1.0, 2e-3) << c.what << ": measured " << measured << ", Jacobian " << j;
  }
}

// ∫ over the directions from y₁ that meet a square S of the plane, of 1 dω (S's solid angle from y₁),
// estimated from cosine-weighted directions at x₁: each that meets S is shifted to y₁ and weighs J / p(ω_x).
// Without J it estimates S's solid angle from x₁ instead.
TEST(ReconnectionShift, ReusingSamplesAtAnotherVertexIsUnbiasedOnlyWithTheJacobian) {
  const Configuration c{D3(0.0), D3(0, 1, 0), D3(0.3, 0.6, 0.2), D3(-0.5, 0.9, 0.4), "floor"};
  const D3 corner[4] = {D3(-0.6, 0, -0.5), D3(0.6, 0, -0.5), D3(0.6, 0, 0.7), D3(-0.6, 0, 0.7)};
  const auto squareAngle = [&](const D3& o) {
    D3 d[4];
    for (int i = 0; i < 4; ++i) d[i] = glm::normalize(corner[i] - o);
    return SolidAngle(d[0], d[1], d[2]) + SolidAngle(d[0], d[2], d[3]);
  };
  const double truth = squareAngle(c.y1), unshifted = squareAngle(c.x1);
  constexpr int kSamples = 200000;
  double sum = 0.0, sumSq = 0.0, sumPlain = 0.0, sumPlainSq = 0.0;
  D3 t, b;
  Tangents(D3(0, -1, 0), t, b);  // x₁ looks down at the floor: its hemisphere is about -Y
  for (int k = 0; k < kSamples; ++k) {
    const RngKey key{11, 0, uint32_t(k), uint32_t(RngPass::kTest)};
    const double r = std::sqrt(double(UniformFloat(key, 0))), phi = 2.0 * M_PI * UniformFloat(key, 1);
    const double cosTheta = std::sqrt(std::max(0.0, 1.0 - r * r));
    const D3 w = r * std::cos(phi) * t + r * std::sin(phi) * b + cosTheta * D3(0, -1, 0);
    const double pdf = cosTheta / M_PI;
    double value = 0.0, plain = 0.0;
    if (pdf > 0.0) {
      const D3 x2 = HitPlane(c.point, c.n, c.x1, w);
      if (x2.x > -0.6 && x2.x < 0.6 && x2.z > -0.5 && x2.z < 0.7) {
        plain = 1.0 / pdf;
        value = ReconnectionJacobian(Vec3(c.x1), Vec3(c.y1), Vec3(x2), Vec3(c.n)) / pdf;
      }
    }
    sum += value;
    sumSq += value * value;
    sumPlain += plain;
    sumPlainSq += plain * plain;
  }
  const auto z = [&](double s, double sq, double target) {
    const double mean = s / kSamples, var = (sq / kSamples - mean * mean) / (kSamples - 1);
    return (mean - target) / std::sqrt(var);
  };
  const double withJ = z(sum, sumSq, truth), without = z(sumPlain, sumPlainSq, truth);
  std::printf(
      "  square's solid angle from y1 %.5f (from x1 %.5f): with the Jacobian z = %+.2f, without z = %+.1f\n",
      truth, unshifted, withJ, without);
  // Normal quantile of a two-sided false-failure rate of 1e-4 (the mean of 200,000 samples of a bounded
  // variable).
  EXPECT_LT(std::fabs(withJ), 3.89);
  EXPECT_GT(std::fabs(without), 20.0) << "the test cannot tell the Jacobian from none";
}

}  // namespace reconnection_shift_test
}  // namespace restir
