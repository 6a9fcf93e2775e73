// The spawn rule of core/shadow_ray.h as geometry, checked in double precision over a grid of configurations
// (emitters tilted from facing the receiver to edge-on, receivers from 1 mm to 30 m away, scenes from the origin
// to 10 km from it): the segment leaves the receiver on the light's side, stops on the front of the emitter, runs
// from the offset origin to the offset end, never crosses the emitter's plane inside the emitter, and is offset
// by a float-error bound, not a length. The rule it replaces (tests/old_shadow_ray.h) crosses the
// emitter inside it at grazing emission: the counter-example. tests/sim/scene/spawned_ray_test.cpp checks the same
// rule against Embree's intersector.
#include "core/shadow_ray.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/light.h"
#include "old_shadow_ray.h"

namespace restir {
namespace {

using DVec3 = glm::dvec3;

// Whether the segment org + t dir, t in (0, tmax], meets triangle (p0, e1, e2), in double.
bool SegmentMeetsTriangle(const ShadowRaySegment& r, const LightTriangle& t) {
  const DVec3 o(r.org), d(r.dir), p0(t.p0), e1(t.e1), e2(t.e2);
  const DVec3 pv = glm::cross(d, e2);
  const double det = glm::dot(e1, pv);
  if (det == 0.0) return false;
  const DVec3 tv = o - p0, qv = glm::cross(tv, e1);
  const double u = glm::dot(tv, pv) / det, v = glm::dot(d, qv) / det, s = glm::dot(e2, qv) / det;
  return u >= 0 && v >= 0 && u + v <= 1 && s > 0 && s <= double(r.tmax);
}

struct Case {
  LightTriangle light;
  Vec3 y, x, nx;
};

// A quad-light triangle tilted `tiltDeg` from facing straight down, centred `shift` from the origin, a point y on
// it, and a floor receiver x (normal +y) in front of the light's plane: up to `distance` away, or (planeDistance
// > 0, tilt > 0) that far in front of the plane, in the band where emission is grazing.
Case MakeCase(float tiltDeg, float shift, float distance, std::mt19937& rng, float planeDistance = 0.0f) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float a = glm::radians(tiltDeg);
  const Vec3 n(std::sin(a), -std::cos(a), 0.0f);  // emits down and towards +x
  const Vec3 c(shift, 1.0f, 0.3f * shift);
  const Vec3 tu = Vec3(std::cos(a), std::sin(a), 0.0f), tv(0.0f, 0.0f, 1.0f);
  Case k;
  const Vec3 p0 = c - 0.5f * tu - 0.5f * tv, p1 = c + 0.5f * tu - 0.5f * tv, p2 = c + 0.5f * tu + 0.5f * tv;
  // Counter-clockwise seen from n.
  if (glm::dot(glm::cross(p1 - p0, p2 - p0), n) > 0) MakeLightTriangle(p0, p1, p2, Vec3(1.0f), k.light);
  else MakeLightTriangle(p0, p2, p1, Vec3(1.0f), k.light);
  k.y = SampleTrianglePoint(k.light, u(rng), u(rng));
  // On the floor y = c.y - 1, in front of the light's plane, `distance` from y in the plane's horizontal reach.
  k.nx = Vec3(0, 1, 0);
  for (;;) {
    Vec3 x(k.y.x + distance * (u(rng) * 2 - 0.2f), c.y - 1.0f, k.y.z + distance * (u(rng) * 2 - 1));
    if (planeDistance > 0.0f) x.x += (planeDistance - glm::dot(x - k.y, k.light.normal)) / k.light.normal.x;
    if (glm::dot(x - k.y, k.light.normal) > 0.0f) {
      k.x = x;
      return k;
    }
  }
}

float MaxAbs(const Vec3& p) { return std::max(std::fabs(p.x), std::max(std::fabs(p.y), std::fabs(p.z))); }

ShadowRaySegment NewSegment(const Case& k) {
  return ShadowRaySetup(k.x, k.nx, MaxAbs(k.x), k.y, k.light.normal, k.light.errorScale);
}

TEST(ShadowRaySetup, SegmentLeavesReceiverAndEmitterOnTheirFrontSides) {
  std::mt19937 rng(13);
  for (float tilt : {0.0f, 45.0f, 80.0f, 89.0f, 89.9f})
    for (float shift : {0.0f, 10.0f, 100.0f, 1000.0f, 10000.0f})
      for (float distance : {1e-3f, 0.1f, 1.0f, 30.0f})
        for (int k = 0; k < 50; ++k) {
          const Case c = MakeCase(tilt, shift, distance, rng);
          const ShadowRaySegment r = NewSegment(c);
          const DVec3 org(r.org), end = org + double(r.tmax) * DVec3(r.dir);
          // The origin on the light's side of the receiver plane, the end in front of the emitter's plane.
          EXPECT_GT(glm::dot(org - DVec3(c.x), DVec3(c.nx)), 0.0) << tilt << " " << shift << " " << distance;
          EXPECT_GT(glm::dot(end - DVec3(c.y), DVec3(c.light.normal)), 0.0) << tilt << " " << shift << " " << distance;
          // The direction is that of the offset segment: org + dir tmax lands within float error of the end.
          const Vec3 back = r.org - c.y;
          const DVec3 wantEnd(OffsetRayOrigin(c.y, c.light.normal, c.light.errorScale + glm::length(back), back));
          EXPECT_LT(glm::length(end - wantEnd), 4e-7 * (double(r.tmax) + MaxAbs(c.y)));
        }
}

// Counter-example: a light tilted towards grazing, receivers on the floor 1 mm to 10 cm in front of its plane.
// The old rule's segment (origin lifted, direction kept) ends behind the emitter's plane and so crosses the
// emitter itself: the sample counts as shadowed. The new one never does.
TEST(ShadowRaySetup, NeverCrossesTheEmitterItAimsAtWhereTheOldRuleDid) {
  std::mt19937 rng(89);
  for (float shift : {0.0f, 10.0f, 100.0f, 1000.0f}) {
    int oldCrossings = 0, newCrossings = 0, cases = 0;
    for (float tilt : {45.0f, 80.0f, 89.0f})
      for (float planeDistance : {1e-3f, 1e-2f, 0.1f})
        for (int k = 0; k < 200; ++k) {
          const Case c = MakeCase(tilt, shift, 1.0f, rng, planeDistance);
          // The old rule's own tmax would stop it short of y; ask whether the segment meets the emitter at all.
          oldCrossings += SegmentMeetsTriangle(OldShadowRaySetup(c.x, c.nx, c.y), c.light);
          newCrossings += SegmentMeetsTriangle(NewSegment(c), c.light);
          ++cases;
        }
    std::printf("scene %g m from the origin: old rule crosses its emitter in %d of %d segments, new in %d\n", shift,
                oldCrossings, cases, newCrossings);
    EXPECT_EQ(newCrossings, 0) << shift;
    EXPECT_GT(oldCrossings, cases / 50) << shift;  // the counter-example is real at every distance
  }
}

// The offsets are float-error bounds, set by the error scales and the segment's length alone: the origin moves by
// kSpawnRelativeOffset errorScale ‖n‖₁ whatever the light's distance, and never by more than 2e-6 of the scale
// (the old rule moved it 1e-4 (1 + |x|)).
TEST(ShadowRaySetup, OffsetsAreFloatErrorBoundsNotLengths) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (float scale : {1e-3f, 1.0f, 1e3f, 1e6f}) {
    for (int k = 0; k < 200; ++k) {
      const Vec3 x = scale * Vec3(u(rng), u(rng), u(rng));
      const Vec3 n = glm::normalize(Vec3(u(rng), u(rng), u(rng)));
      const float errorScale = MaxAbs(x);
      const Vec3 near = x + 0.01f * scale * n, far = x + 100.0f * scale * n;
      const Vec3 a = OffsetRayOrigin(x, n, errorScale, near - x), b = OffsetRayOrigin(x, n, errorScale, far - x);
      EXPECT_EQ(a, b);
      const double moved = glm::length(DVec3(a) - DVec3(x));
      const double bound = double(kSpawnRelativeOffset) * errorScale * NormL1(n);
      EXPECT_NEAR(moved, bound, 1e-6 * errorScale) << scale;
      EXPECT_LE(moved, 2e-6 * errorScale) << scale;
    }
  }
  EXPECT_EQ(OffsetRayOrigin(Vec3(0.5f), Vec3(0, 1, 0), 0.0f, Vec3(0, 1, 0)), Vec3(0.5f));
}

}  // namespace
}  // namespace restir
