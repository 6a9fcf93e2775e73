#include "sim/scene/embree_scene.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "tests/sim/mesh_fixtures.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace embree_scene_test {

constexpr float kInf = std::numeric_limits<float>::infinity();

using test::BoxMesh;
using test::MakeObject;
using test::QuadMesh;
using test::Trs;
using test::BaseSequence;
using test::QuadLight;
using test::StateFor;
using test::TestRng;

void ExpectVecNear(const Vec3& a, const Vec3& b, float tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}


TEST(EmbreeScene, IntersectQuadGivesAnalyticDistanceAndNormal) {
  Sequence s = BaseSequence();
  s.objects.push_back(MakeObject("quad", QuadMesh(), false, 1));
  EmbreeScene scene(s);
  scene.Update(StateFor(s, {Trs(Vec3(0, 0, -5), Vec3(0), Vec3(2, 2, 1))}));

  const SurfaceHit front = scene.Intersect(Vec3(0.3f, -0.4f, 0), Vec3(0, 0, -1), kInf);
  ASSERT_TRUE(front.hit);
  EXPECT_NEAR(front.t, 5.0f, 1e-5f);
  ExpectVecNear(front.position, Vec3(0.3f, -0.4f, -5), 1e-5f);
  ExpectVecNear(front.geometricNormal, Vec3(0, 0, 1), 1e-6f);
  ExpectVecNear(front.shadingNormal, Vec3(0, 0, 1), 1e-6f);
  EXPECT_EQ(front.objectId, 0);
  EXPECT_EQ(front.materialId, 1);
  EXPECT_EQ(front.lightId, -1);

  // Two-sided: from behind, the normal faces the ray origin.
  const SurfaceHit back = scene.Intersect(Vec3(0.3f, -0.4f, -12), Vec3(0, 0, 1), kInf);
  ASSERT_TRUE(back.hit);
  EXPECT_NEAR(back.t, 7.0f, 1e-5f);
  ExpectVecNear(back.geometricNormal, Vec3(0, 0, -1), 1e-6f);

  // Oblique ray: t = 5 / |d_z|.
  const Vec3 d = glm::normalize(Vec3(0.2f, 0.1f, -1.0f));
  const SurfaceHit obl = scene.Intersect(Vec3(0), d, kInf);
  ASSERT_TRUE(obl.hit);
  EXPECT_NEAR(obl.t, 5.0f / std::fabs(d.z), 1e-5f);

  EXPECT_FALSE(scene.Intersect(Vec3(2.5f, 0, 0), Vec3(0, 0, -1), kInf).hit);  // beside the quad
  EXPECT_FALSE(scene.Intersect(Vec3(0), Vec3(0, 0, -1), 4.9f).hit);          // tmax before it
  EXPECT_TRUE(scene.Occluded(Vec3(0), Vec3(0, 0, -1), 5.1f));
  EXPECT_FALSE(scene.Occluded(Vec3(0), Vec3(0, 0, -1), 4.9f));
  EXPECT_FALSE(scene.Occluded(Vec3(2.5f, 0, 0), Vec3(0, 0, -1), kInf));
}

TEST(EmbreeScene, IntersectInstancedTransformedBoxGivesAnalyticDistanceAndNormal) {
  Sequence s = BaseSequence();
  s.objects.push_back(MakeObject("box", BoxMesh(), true));
  EmbreeScene scene(s);
  const Mat4 m = Trs(Vec3(3, 1, -6), Vec3(20, 30, 0), Vec3(2, 1, 0.5f));
  scene.Update(StateFor(s, {m}));
  const glm::mat3 nm = glm::transpose(glm::inverse(glm::mat3(m)));

  for (int a = 0; a < 3; ++a) {
    for (float sgn : {1.0f, -1.0f}) {
      Vec3 nObj(0.0f);
      nObj[a] = sgn;
      Vec3 tObj(0.0f);
      tObj[(a + 1) % 3] = 0.2f;  // stay inside the face
      const Vec3 centre = Vec3(m * Vec4(0.5f * nObj + tObj, 1.0f));
      const Vec3 nW = glm::normalize(nm * nObj);
      const Vec3 org = centre + 4.0f * nW;
      const SurfaceHit h = scene.Intersect(org, -nW, kInf);
      ASSERT_TRUE(h.hit) << "face " << a << " " << sgn;
      EXPECT_NEAR(h.t, 4.0f, 2e-5f);
      ExpectVecNear(h.position, centre, 2e-5f);
      ExpectVecNear(h.geometricNormal, nW, 1e-5f);
      ExpectVecNear(h.shadingNormal, nW, 1e-5f);
      EXPECT_EQ(h.objectId, 0);
      EXPECT_EQ(h.materialId, 0);
      EXPECT_TRUE(scene.Occluded(org, -nW, 4.01f));
      EXPECT_FALSE(scene.Occluded(org, -nW, 3.99f));
    }
  }
}

TEST(EmbreeScene, ShadingNormalInterpolatesVertexNormalsThroughTransform) {
  Sequence s = BaseSequence();
  Mesh q = QuadMesh();
  // Vertex normals tilting linearly in x: interpolation at x gives normalize(x * 0.5, 0, 1).
  q.normals = {Vec3(-0.5f, 0, 1), Vec3(0.5f, 0, 1), Vec3(0.5f, 0, 1), Vec3(-0.5f, 0, 1)};
  s.objects.push_back(MakeObject("quad", q, true));
  EmbreeScene scene(s);
  const Mat4 m = Trs(Vec3(0, 0, -5), Vec3(0, 90, 0), Vec3(1));  // quad now faces +x at z=-5
  scene.Update(StateFor(s, {m}));
  const glm::mat3 nm = glm::transpose(glm::inverse(glm::mat3(m)));
  // Object point (0.4, 0.1, 0) → world m * p; shoot at it from +x.
  const Vec3 target = Vec3(m * Vec4(0.4f, 0.1f, 0.0f, 1.0f));
  const SurfaceHit h = scene.Intersect(target + Vec3(3, 0, 0), Vec3(-1, 0, 0), kInf);
  ASSERT_TRUE(h.hit);
  ExpectVecNear(h.geometricNormal, Vec3(1, 0, 0), 1e-5f);
  ExpectVecNear(h.shadingNormal, glm::normalize(nm * Vec3(0.2f, 0, 1)), 1e-5f);
  // From the other side both normals flip together.
  const SurfaceHit b = scene.Intersect(target - Vec3(3, 0, 0), Vec3(1, 0, 0), kInf);
  ASSERT_TRUE(b.hit);
  ExpectVecNear(b.shadingNormal, -glm::normalize(nm * Vec3(0.2f, 0, 1)), 1e-5f);
}

TEST(EmbreeScene, EmitterHitReportsLightIdAndFrontFace) {
  Sequence s = BaseSequence();
  s.objects.push_back(MakeObject("floor", QuadMesh(), false));
  s.lights.push_back(QuadLight("ceiling", 2.0f, Vec3(5)));
  EmbreeScene scene(s);
  EXPECT_EQ(scene.LightObjectId(), 1);
  scene.Update(StateFor(s, {Trs(Vec3(0, -1, 0), Vec3(-90, 0, 0), Vec3(3))}));
  ASSERT_EQ(scene.LightTriangles().size(), 2u);

  // The light emits downwards; (0.5, -0.5) lies in triangle 0 (a,b,c), (-0.5, 0.5) in triangle 1 (a,c,d).
  const SurfaceHit up = scene.Intersect(Vec3(0.5f, 0, -0.5f), Vec3(0, 1, 0), kInf);
  ASSERT_TRUE(up.hit);
  EXPECT_EQ(up.objectId, scene.LightObjectId());
  EXPECT_EQ(up.materialId, -1);
  EXPECT_EQ(up.lightId, 0);
  EXPECT_TRUE(up.frontFace);
  EXPECT_NEAR(up.t, 2.0f, 1e-5f);
  ExpectVecNear(up.geometricNormal, Vec3(0, -1, 0), 1e-6f);

  const SurfaceHit down = scene.Intersect(Vec3(-0.5f, 5, 0.5f), Vec3(0, -1, 0), kInf);
  ASSERT_TRUE(down.hit);
  EXPECT_EQ(down.lightId, 1);
  EXPECT_FALSE(down.frontFace);
  ExpectVecNear(down.geometricNormal, Vec3(0, 1, 0), 1e-6f);

  const SurfaceHit floorHit = scene.Intersect(Vec3(0.2f, 0, 0.3f), Vec3(0, -1, 0), kInf);
  ASSERT_TRUE(floorHit.hit);
  EXPECT_EQ(floorHit.objectId, 0);
  EXPECT_EQ(floorHit.lightId, -1);
  ExpectVecNear(floorHit.geometricNormal, Vec3(0, 1, 0), 1e-6f);
}

TEST(BuildLightTriangles, SwitchedOffLightHasZeroRadianceAndKeepsIndices) {
  Sequence s = BaseSequence();
  s.lights.push_back(QuadLight("a", 2.0f, Vec3(1, 2, 3)));
  s.lights.push_back(QuadLight("b", 3.0f, Vec3(4)));
  FrameState st = StateFor(s, {});
  st.lightOn = {1, 0};
  std::vector<uint32_t> group;
  const auto tris = BuildLightTriangles(s, st, &group);
  ASSERT_EQ(tris.size(), 4u);
  EXPECT_EQ(group, (std::vector<uint32_t>{0, 0, 1, 1}));
  EXPECT_EQ(tris[0].radiance, Vec3(1, 2, 3));
  EXPECT_EQ(tris[2].radiance, Vec3(0));
  EXPECT_NEAR(tris[3].area, 2.0f, 1e-6f);
  ExpectVecNear(tris[3].normal, Vec3(0, -1, 0), 1e-6f);

  EmbreeScene scene(s);
  scene.Update(st);
  EXPECT_EQ(scene.LightTriangles()[2].radiance, Vec3(0));
  EXPECT_EQ(scene.LightGroupOf(), group);
  st.lightOn = {0, 1};
  scene.Update(st);
  EXPECT_EQ(scene.LightTriangles()[0].radiance, Vec3(0));
  EXPECT_EQ(scene.LightTriangles()[2].radiance, Vec3(4));
  // A switched-off light still occludes: it is geometry.
  EXPECT_TRUE(scene.Occluded(Vec3(0), Vec3(0, 1, 0), 10.0f));
}

TEST(EmbreeScene, PreviousFrameQueriesSeePreviousTransforms) {
  Sequence s = BaseSequence();
  s.objects.push_back(MakeObject("box", BoxMesh(), true));
  EmbreeScene scene(s);
  auto at = [](float x) { return Trs(Vec3(x, 0, -5), Vec3(0), Vec3(1)); };
  auto hitsAt = [&](float x, SceneFrame f) {
    const SurfaceHit h = scene.Intersect(Vec3(x, 0, 0), Vec3(0, 0, -1), kInf, f);
    return h.hit && std::fabs(h.t - 4.5f) < 1e-5f;
  };

  // Before any Update: nothing to hit.
  EXPECT_FALSE(scene.Intersect(Vec3(0), Vec3(0, 0, -1), kInf).hit);

  scene.Update(StateFor(s, {at(0)}));
  // Before a second frame, previous == current.
  EXPECT_TRUE(hitsAt(0, SceneFrame::kCurrent));
  EXPECT_TRUE(hitsAt(0, SceneFrame::kPrevious));

  scene.Update(StateFor(s, {at(3)}, 1));
  EXPECT_TRUE(hitsAt(3, SceneFrame::kCurrent));
  EXPECT_FALSE(hitsAt(0, SceneFrame::kCurrent));
  EXPECT_TRUE(hitsAt(0, SceneFrame::kPrevious));
  EXPECT_FALSE(hitsAt(3, SceneFrame::kPrevious));
  EXPECT_TRUE(scene.Occluded(Vec3(0), Vec3(0, 0, -1), 10.0f, SceneFrame::kPrevious));
  EXPECT_FALSE(scene.Occluded(Vec3(0), Vec3(0, 0, -1), 10.0f, SceneFrame::kCurrent));

  scene.Update(StateFor(s, {at(6)}, 2));
  EXPECT_TRUE(hitsAt(6, SceneFrame::kCurrent));
  EXPECT_TRUE(hitsAt(3, SceneFrame::kPrevious));
  EXPECT_FALSE(hitsAt(0, SceneFrame::kPrevious));
}

TEST(EmbreeScene, OccludedBatchMatchesOccludedForRandomRays) {
  Sequence s = BaseSequence();
  s.objects.push_back(MakeObject("floor", QuadMesh(), false));
  s.objects.push_back(MakeObject("boxA", BoxMesh(), false));
  s.objects.push_back(MakeObject("boxB", BoxMesh(), true));
  s.objects.push_back(MakeObject("boxC", BoxMesh(), true));
  s.lights.push_back(QuadLight("l", 4.0f, Vec3(3)));
  EmbreeScene scene(s);
  auto state = [&](float phase, int frame) {
    return StateFor(s,
                    {Trs(Vec3(0, -2, 0), Vec3(-90, 0, 0), Vec3(6)), Trs(Vec3(-2, -1, 1), Vec3(0, 10, 0), Vec3(1.5f)),
                     Trs(Vec3(2 * std::cos(phase), 0, 2 * std::sin(phase)), Vec3(phase * 30, phase * 50, 0), Vec3(1)),
                     Trs(Vec3(0, 1.5f, -1 + phase), Vec3(0, 0, 45), Vec3(2, 0.3f, 2))},
                    frame);
  };
  scene.Update(state(0.0f, 0));
  scene.Update(state(0.7f, 1));

  TestRng rng{0x9e3779b97f4a7c15ull};
  constexpr size_t kRays = 6000;
  std::vector<ShadowRay> rays(kRays);
  for (size_t i = 0; i < kRays; ++i) {
    ShadowRay& r = rays[i];
    r.org = Vec3(rng.Range(-5, 5), rng.Range(-3, 5), rng.Range(-5, 5));
    const Vec3 target(rng.Range(-3, 3), rng.Range(-2.5f, 4.5f), rng.Range(-3, 3));
    r.dir = glm::normalize(target - r.org);
    const float dist = glm::length(target - r.org);
    switch (i % 4) {
      case 0: r.tmax = dist; break;
      case 1: r.tmax = rng.Range(0.0f, 20.0f); break;
      case 2: r.tmax = kInf; break;
      default: {
        // End just short of / just past the first surface: the hardest cases for agreement.
        const SurfaceHit h = scene.Intersect(r.org, r.dir, kInf);
        r.tmax = h.hit ? h.t * (i % 8 == 3 ? 0.999999f : 1.000001f) : dist;
      }
    }
  }
  for (SceneFrame f : {SceneFrame::kCurrent, SceneFrame::kPrevious}) {
    std::vector<uint8_t> batch(kRays, 7);
    scene.OccludedBatch(rays.data(), batch.data(), kRays, f);
    size_t mismatches = 0, blocked = 0;
    for (size_t i = 0; i < kRays; ++i) {
      const bool single = scene.Occluded(rays[i].org, rays[i].dir, rays[i].tmax, f);
      mismatches += (batch[i] != 0) != single || batch[i] > 1;
      blocked += single;
    }
    EXPECT_EQ(mismatches, 0u);
    // The scene must block a fair share, or the comparison says nothing.
    EXPECT_GT(blocked, kRays / 5);
    EXPECT_LT(blocked, kRays * 4 / 5);
  }
  // An odd count exercises the partial last packet.
  std::vector<uint8_t> tail(37, 7);
  scene.OccludedBatch(rays.data(), tail.data(), tail.size());
  for (size_t i = 0; i < tail.size(); ++i)
    EXPECT_EQ(tail[i] != 0, scene.Occluded(rays[i].org, rays[i].dir, rays[i].tmax));
}

// IntersectEmitter (the reference's BSDF rays under a sky) answers what the reference reads of Intersect: every
// miss and every emitter hit field for field (t, light, side, position, normals, error scale), and on any other hit
// whether it hit and what; FirstEmitter (its skyless BSDF rays) the emitter, side and distance; on static and
// animated instances, both frames, and rays that start on a surface.
TEST(EmbreeScene, IntersectEmitterAgreesWithIntersectOnMissesAndEmitters) {
  Sequence s = BaseSequence();
  s.objects.push_back(MakeObject("floor", QuadMesh(), false));
  s.objects.push_back(MakeObject("boxA", BoxMesh(), false));
  s.objects.push_back(MakeObject("boxB", BoxMesh(), true));
  s.lights.push_back(QuadLight("l", 4.0f, Vec3(3)));
  EmbreeScene scene(s);
  auto state = [&](float phase, int frame) {
    return StateFor(
        s,
        {Trs(Vec3(0, -2, 0), Vec3(-90, 0, 0), Vec3(6)), Trs(Vec3(-2, -1, 1), Vec3(0, 10, 0), Vec3(1.5f)),
         Trs(Vec3(2 * std::cos(phase), 0, 2 * std::sin(phase)), Vec3(phase * 30, phase * 50, 0), Vec3(1))},
        frame);
  };
  scene.Update(state(0.0f, 0));
  scene.Update(state(0.7f, 1));
  TestRng rng{0x51ed270b27e3a4c1ull};
  size_t emitters = 0, objects = 0, misses = 0, firstEmitters = 0;
  for (SceneFrame f : {SceneFrame::kCurrent, SceneFrame::kPrevious}) {
    for (int i = 0; i < 20000; ++i) {
      Vec3 org(rng.Range(-5, 5), rng.Range(-3, 5), rng.Range(-5, 5));
      const Vec3 target(rng.Range(-3, 3), rng.Range(-2.5f, 4.5f), rng.Range(-3, 3));
      Vec3 dir = glm::normalize(target - org);
      if (i % 5 == 0) {  // from a surface point, as a BSDF ray leaves its receiver
        const SurfaceHit h = scene.Intersect(org, dir, kInf, f);
        if (h.hit) org = h.position, dir = glm::normalize(Vec3(rng.Range(-1, 1), 1.0f, rng.Range(-1, 1)));
      }
      const float tmax = i % 3 == 0 ? rng.Range(0.0f, 12.0f) : kInf;
      const SurfaceHit full = scene.Intersect(org, dir, tmax, f);
      const SurfaceHit light = scene.IntersectEmitter(org, dir, tmax, f);
      if (tmax == kInf) {
        // FirstEmitter (the reference's skyless BSDF rays): the same emitter and side, at Embree's own distance,
        // within rounding of Intersect's refined one.
        const EmitterHit first = scene.FirstEmitter(org, dir, f);
        ASSERT_EQ(first.lightId, full.hit ? full.lightId : -1) << i;
        if (first.lightId >= 0) {
          EXPECT_EQ(first.frontFace, full.frontFace) << i;
          EXPECT_NEAR(first.t, full.t, 1e-5f * full.t) << i;
          ++firstEmitters;
        }
      }
      ASSERT_EQ(light.hit, full.hit) << i;
      ASSERT_EQ(light.lightId, full.lightId) << i;
      ASSERT_EQ(light.objectId, full.objectId) << i;
      ASSERT_EQ(light.materialId, full.materialId) << i;
      if (!full.hit) {
        ++misses;
      } else if (full.lightId >= 0) {
        ++emitters;
        EXPECT_EQ(light.t, full.t);
        EXPECT_EQ(light.frontFace, full.frontFace);
        EXPECT_EQ(light.position, full.position);
        EXPECT_EQ(light.geometricNormal, full.geometricNormal);
        EXPECT_EQ(light.errorScale, full.errorScale);
      } else {
        ++objects;
      }
    }
  }
  EXPECT_GT(emitters, 300u);
  EXPECT_GT(firstEmitters, 150u);
  EXPECT_GT(objects, 10000u);
  EXPECT_GT(misses, 1000u);
}

}  // namespace embree_scene_test
}  // namespace restir
