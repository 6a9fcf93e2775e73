// What only the benchmarks' library (restir_sim_probe, sim/scene/embree_probe.h) has: the observer of every query that
// records a frame's rays and can answer them in Embree's place, and every Embree shadow-ray entry point, which
// must all answer as EmbreeScene::OccludedBatch does.
#include "sim/scene/embree_probe.h"
#include "sim/scene/embree_scene.h"

#include <gtest/gtest.h>

#include <vector>

#include "tests/sim/mesh_fixtures.h"

namespace restir {
namespace {

using test::BaseSequence;
using test::BoxMesh;
using test::MakeObject;
using test::QuadLight;
using test::QuadMesh;
using test::StateFor;
using test::TestRng;
using test::Trs;

// Every Embree entry point gives the answers of Occluded for random rays (ends near surfaces included), in the
// current and the previous frame (bench/frame_bench.cpp compares their speed).
TEST(EmbreeProbe, EveryOcclusionEntryPointAnswersAsOccluded) {
  Sequence s = BaseSequence();
  s.objects.push_back(MakeObject("floor", QuadMesh(), false));
  s.objects.push_back(MakeObject("box", BoxMesh(), true));
  s.lights.push_back(QuadLight("l", 4.0f, Vec3(3)));
  EmbreeScene scene(s);
  scene.Update(StateFor(s, {Trs(Vec3(0, -2, 0), Vec3(-90, 0, 0), Vec3(6)), Trs(Vec3(0, 0, 0), Vec3(0), Vec3(2))}, 0));
  scene.Update(StateFor(s, {Trs(Vec3(0, -2, 0), Vec3(-90, 0, 0), Vec3(6)), Trs(Vec3(1, 0, 0), Vec3(0, 30, 0), Vec3(2))}, 1));
  TestRng rng{0x2545F4914F6CDD1Dull};
  std::vector<ShadowRay> rays(3001);  // not a multiple of any packet width
  for (ShadowRay& r : rays) {
    r.org = Vec3(rng.Range(-4, 4), rng.Range(-1.5f, 3.5f), rng.Range(-4, 4));
    const Vec3 target(rng.Range(-3, 3), rng.Range(-2.5f, 3.5f), rng.Range(-3, 3));
    r.dir = glm::normalize(target - r.org);
    r.tmax = rng.Next() < 0.1f ? 0.0f : glm::length(target - r.org);  // some inactive rays
  }
  for (OcclusionApi api : {OcclusionApi::k1, OcclusionApi::k4, OcclusionApi::k8, OcclusionApi::k16,
                           OcclusionApi::kStream1M}) {
    for (SceneFrame f : {SceneFrame::kCurrent, SceneFrame::kPrevious}) {
      std::vector<uint8_t> batch(rays.size(), 7);
      OccludedBatch(scene, api, rays.data(), batch.data(), batch.size(), f);
      size_t mismatches = 0, blocked = 0;
      for (size_t i = 0; i < batch.size(); ++i) {
        const bool single = scene.Occluded(rays[i].org, rays[i].dir, rays[i].tmax, f);
        mismatches += (batch[i] != 0) != single || batch[i] > 1;
        blocked += single;
        EXPECT_EQ(OccludedRaw(scene, rays[i].org, rays[i].dir, rays[i].tmax, f), single);
      }
      EXPECT_EQ(mismatches, 0u) << "api " << static_cast<int>(api);
      EXPECT_GT(blocked, rays.size() / 10);
    }
  }
}

// The benchmark's RayHook sees every query with Embree's answer, and can answer in Embree's place.
TEST(EmbreeProbe, RayHookRecordsAndAnswersQueries) {
  Sequence s = BaseSequence();
  s.objects.push_back(MakeObject("floor", QuadMesh(), false));
  s.lights.push_back(QuadLight("l", 4.0f, Vec3(3)));
  EmbreeScene scene(s);
  scene.Update(StateFor(s, {Trs(Vec3(0, -2, 0), Vec3(-90, 0, 0), Vec3(6))}, 0));
  struct Hook : RayHook {
    bool answer = false;
    mutable int occluded = 0, intersect = 0, answered = 0;
    bool AnswerOccluded(const Vec3&, const Vec3&, float, SceneFrame, bool& o) const override {
      if (!answer) return false;
      ++answered;
      o = true;
      return true;
    }
    void TracedOccluded(const Vec3&, const Vec3&, float, SceneFrame, bool) const override { ++occluded; }
    void TracedIntersect(const Vec3&, const Vec3&, float, SceneFrame, const RawHit& h) const override {
      ++intersect;
      EXPECT_NE(h.geomId, 0xffffffffu);
    }
  } hook;
  const Vec3 org(0, 0, 0), down(0, -1, 0), up(0, 1, 0);  // floor 2 below, light 4 above: up to 3 is clear
  const bool blockedBelow = scene.Occluded(org, down, 10.0f);
  EXPECT_TRUE(blockedBelow);
  const SurfaceHit below = scene.Intersect(org, down, 100.0f);
  SetRayHook(scene, &hook);
  EXPECT_EQ(scene.Occluded(org, down, 10.0f), blockedBelow);
  EXPECT_FALSE(scene.Occluded(org, up, 3.0f));
  const SurfaceHit hooked = scene.Intersect(org, down, 100.0f);
  EXPECT_EQ(hooked.t, below.t);
  EXPECT_EQ(hook.occluded, 2);
  EXPECT_EQ(hook.intersect, 1);
  hook.answer = true;
  EXPECT_TRUE(scene.Occluded(org, up, 3.0f));
  EXPECT_EQ(hook.answered, 1);
  EXPECT_EQ(hook.occluded, 2);
  SetRayHook(scene, nullptr);
  EXPECT_FALSE(scene.Occluded(org, up, 3.0f));
  EXPECT_EQ(hook.answered, 1);
}

}  // namespace
}  // namespace restir
