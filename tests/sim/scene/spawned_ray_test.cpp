// The spawn rule of core/shadow_ray.h against Embree's own intersector, over a grid of configurations: surfaces
// at 0 to 10 km from the world origin, 1 cm to 100 m across, tilted at random, static (baked to world space) and
// instanced (moved by a transform, rigid or stretched), rays from steep to grazing (cos 1e-4), on every Embree
// ISA this CPU has. Properties:
// - a ray spawned off a surface never hits that surface (the receiver is the only geometry in its scene, so any
//   hit is a self-hit);
// - a shadow ray aimed at a point on an emitter never hits that emitter, at grazing emission too;
// - it never jumps an occluder: a sheet a few spawn offsets above the receiver blocks every ray through it.
// The offset has margin: a quarter of it leaves no self-hit either; a 1/256th of it leaves many, so the test
// can fail (the margins are printed). The points are made as the simulator makes them: receivers by
// EmbreeScene::Intersect from a camera-like origin, light points by SampleTrianglePoint on the light list.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "core/light.h"
#include "core/shadow_ray.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/sequence.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace spawned_ray_test {

constexpr float kInf = std::numeric_limits<float>::infinity();

struct Config {
  float distance;  // from the world origin
  float size;      // half-width of the quad
  bool instanced;  // moved by its transform (Embree instance) rather than baked to world space
  bool stretched;  // the instance scales its axes unevenly (1, 0.25, 4)
};

std::vector<Config> Grid() {
  std::vector<Config> out;
  for (float distance : {0.0f, 10.0f, 100.0f, 1000.0f, 10000.0f})
    for (float size : {0.01f, 1.0f, 100.0f})
      for (int mode = 0; mode < 3; ++mode) out.push_back({distance, size, mode > 0, mode == 2});
  return out;
}

std::string Name(const Config& c) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "distance %g size %g %s", c.distance, c.size,
                c.stretched ? "stretched instance" : c.instanced ? "instance" : "static");
  return buf;
}

Vec3 RandomUnit(std::mt19937& rng) {
  std::normal_distribution<float> g;
  for (;;) {
    const Vec3 v(g(rng), g(rng), g(rng));
    const float l = glm::length(v);
    if (l > 1e-3f) return v / l;
  }
}

// A direction around unit n with cosine `c` to it, azimuth at random.
Vec3 AtCosine(const Vec3& n, float c, std::mt19937& rng) {
  Vec3 t, b;
  OrthonormalBasis(n, t, b);
  const float phi = std::uniform_real_distribution<float>(0.0f, 2.0f * kPi)(rng);
  const float s = std::sqrt(std::max(0.0f, 1.0f - c * c));
  return glm::normalize(c * n + s * (std::cos(phi) * t + std::sin(phi) * b));
}

float MaxAbs(const Vec3& p) { return std::max(std::fabs(p.x), std::max(std::fabs(p.y), std::fabs(p.z))); }

Mat4 RotationTowards(const Vec3& n) {
  Vec3 t, b;
  OrthonormalBasis(n, t, b);
  return Mat4(Vec4(t, 0), Vec4(n, 0), Vec4(b, 0), Vec4(0, 0, 0, 1));  // object +y -> n
}

// One quad (object space: y = 0, |x|, |z| <= size) placed `distance` from the origin with normal n, as the only
// geometry of a scene; optionally a second, parallel quad `lift` above it (the occluder).
struct Placed {
  Sequence seq;
  FrameState state;
  Vec3 center, normal;
};

Placed PlaceQuad(const Config& c, std::mt19937& rng, float lift = 0.0f) {
  Placed p;
  p.normal = RandomUnit(rng);
  p.center = c.distance * RandomUnit(rng);
  const Vec3 s = c.stretched ? Vec3(1.0f, 0.25f, 4.0f) : Vec3(1.0f);
  Mat4 m = RotationTowards(p.normal);
  m[3] = Vec4(p.center, 1.0f);
  const Mat4 toWorld = m * Mat4(Vec4(s.x, 0, 0, 0), Vec4(0, s.y, 0, 0), Vec4(0, 0, s.z, 0), Vec4(0, 0, 0, 1));
  auto quad = [&](float y) {
    Object o;
    o.name = "quad" + std::to_string(p.seq.objects.size());
    const float hx = c.size / s.x, hz = c.size / s.z;  // the same world-space size whatever the stretch
    o.mesh.positions = {Vec3(-hx, y, -hz), Vec3(hx, y, -hz), Vec3(hx, y, hz), Vec3(-hx, y, hz)};
    o.mesh.triangles = {glm::uvec3(0, 1, 2), glm::uvec3(0, 2, 3)};
    o.keys.push_back(TransformKey{});
    o.animated = c.instanced;
    if (!c.instanced) {  // baked: world-space vertices, identity transform
      for (Vec3& v : o.mesh.positions) v = Vec3(toWorld * Vec4(v, 1.0f));
    }
    p.seq.objects.push_back(o);
    p.state.objectToWorld.push_back(c.instanced ? toWorld : Mat4(1.0f));
  };
  Material mat;
  mat.name = "m";
  p.seq.materials.push_back(mat);
  quad(0.0f);
  if (lift > 0.0f) quad(lift / s.y);
  p.state.camera.width = p.state.camera.height = 1;
  return p;
}

// Receivers as the G-buffer makes them: the closest hit of a ray from a camera-like point 3 sizes away.
std::vector<SurfaceHit> Receivers(const EmbreeScene& scene, const Placed& p, float size, int count, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-0.95f, 0.95f);
  Vec3 t, b;
  OrthonormalBasis(p.normal, t, b);
  std::vector<SurfaceHit> out;
  for (int k = 0; k < count; ++k) {
    const Vec3 target = p.center + size * (u(rng) * t + u(rng) * b);
    const Vec3 eye = target + 3.0f * size * AtCosine(p.normal, 0.2f + 0.8f * std::fabs(u(rng)), rng);
    const SurfaceHit h = scene.Intersect(eye, glm::normalize(target - eye), kInf);
    if (h.hit) out.push_back(h);
  }
  return out;
}

constexpr float kCosines[] = {1.0f, 0.5f, 0.1f, 1e-2f, 1e-3f, 1e-4f};

// Self-hits of rays spawned off receivers with the offset scaled by `fraction`, in every direction class.
int SelfHits(const Config& c, float fraction, uint32_t seed) {
  std::mt19937 rng(seed);
  const Placed p = PlaceQuad(c, rng);
  EmbreeScene scene(p.seq);
  scene.Update(p.state);
  int hits = 0;
  for (const SurfaceHit& h : Receivers(scene, p, c.size, 200, rng))
    for (float cosine : kCosines)
      for (int k = 0; k < 4; ++k) {
        const Vec3 w = AtCosine(h.geometricNormal, cosine, rng);
        const Vec3 org = OffsetRayOrigin(h.position, h.geometricNormal, fraction * h.errorScale, w);
        hits += scene.Occluded(org, w, kInf);
      }
  return hits;
}

// Hits on the emitter a shadow ray aims at, the end offset scaled by `fraction`: receivers in front of a quad
// light, from straight ahead to grazing emission, near and far.
int EmitterHits(const Config& c, float fraction, uint32_t seed) {
  std::mt19937 rng(seed);
  const Vec3 n = RandomUnit(rng), center = c.distance * RandomUnit(rng);
  Vec3 t, b;
  OrthonormalBasis(n, t, b);
  Sequence seq;
  Light light;
  light.name = "light";
  const Vec3 q0 = center - c.size * t - c.size * b, q1 = center + c.size * t - c.size * b,
             q2 = center + c.size * t + c.size * b, q3 = center - c.size * t + c.size * b;
  // Counter-clockwise seen from +n (cross(t, b) = n for this basis).
  light.vertices = {q0, q1, q2, q0, q2, q3};
  seq.lights.push_back(light);
  FrameState state;
  state.lightOn = {1};
  EmbreeScene scene(seq);
  scene.Update(state);
  const std::vector<LightTriangle>& lights = scene.LightTriangles();
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int hits = 0;
  for (int k = 0; k < 1200; ++k) {
    const LightTriangle& lt = lights[k % lights.size()];
    const Vec3 y = SampleTrianglePoint(lt, u(rng), u(rng));
    const float cosine = kCosines[k % 6];
    const float reach = c.size * (0.5f + 20.0f * u(rng));
    // A receiver closer to the emitter's plane than float spacing can resolve (at 100 m, 1e-4 of 5 mm) is as
    // much behind it as in front: no rule can answer for it.
    if (reach * cosine < 1e-5f * (MaxAbs(y) + c.size)) continue;
    const Vec3 x = y + reach * AtCosine(lt.normal, cosine, rng);
    const Vec3 nx = glm::normalize(y - x + 0.5f * glm::length(y - x) * RandomUnit(rng));
    const float ex = MaxAbs(x);
    const ShadowRaySegment r = ShadowRaySetup(x, nx, ex, y, lt.normal, fraction * lt.errorScale);
    // The end's offset grows with the segment's length inside ShadowRaySetup; scale that part too.
    const ShadowRaySegment scaled = fraction == 1.0f ? r : [&] {
      const Vec3 org = OffsetRayOrigin(x, nx, ex, y - x);
      const Vec3 back = org - y;
      const Vec3 end = OffsetRayOrigin(y, lt.normal, fraction * (lt.errorScale + glm::length(back)), back);
      return ShadowRaySegment{org, glm::normalize(end - org), glm::length(end - org)};
    }();
    hits += scene.Occluded(scaled.org, scaled.dir, scaled.tmax);
  }
  return hits;
}

class SpawnedRays : public ::testing::Test {
 protected:
  void TearDown() override { SetEmbreeIsa(EmbreeIsa::kSse42); }
};

TEST_F(SpawnedRays, NeverHitTheSurfaceTheyLeaveWithAQuarterOfTheOffset) {
  for (EmbreeIsa isa : {EmbreeIsa::kSse42, EmbreeIsa::kAvx2, EmbreeIsa::kAvx512}) {
    if (!SetEmbreeIsa(isa)) continue;
    int tiny = 0;
    uint32_t seed = 1;
    for (const Config& c : Grid()) {
      EXPECT_EQ(SelfHits(c, 1.0f, seed), 0) << Name(c) << " on " << EmbreeIsaName(isa);
      EXPECT_EQ(SelfHits(c, 0.25f, seed), 0) << Name(c) << " on " << EmbreeIsaName(isa) << ", quarter offset";
      tiny += SelfHits(c, 1.0f / 256.0f, seed);
      ++seed;
    }
    std::printf("%s: self-hits with 1/256 of the offset: %d of %zu rays\n", EmbreeIsaName(isa), tiny,
                Grid().size() * 200 * 24);
    EXPECT_GT(tiny, 100) << "the grid must be hard enough that a too-small offset fails";
  }
}

TEST_F(SpawnedRays, NeverHitTheEmitterTheyAimAtWithAQuarterOfTheOffset) {
  for (EmbreeIsa isa : {EmbreeIsa::kSse42, EmbreeIsa::kAvx2, EmbreeIsa::kAvx512}) {
    if (!SetEmbreeIsa(isa)) continue;
    int tiny = 0;
    uint32_t seed = 100;
    for (const Config& c : Grid()) {
      if (c.instanced) continue;  // lights are static world-space geometry
      EXPECT_EQ(EmitterHits(c, 1.0f, seed), 0) << Name(c) << " on " << EmbreeIsaName(isa);
      EXPECT_EQ(EmitterHits(c, 0.25f, seed), 0) << Name(c) << " on " << EmbreeIsaName(isa) << ", quarter offset";
      tiny += EmitterHits(c, 0.0f, seed);
      ++seed;
    }
    std::printf("%s: emitter hits with no end offset: %d\n", EmbreeIsaName(isa), tiny);
    EXPECT_GT(tiny, 20) << "the grid must be hard enough that a missing end offset fails";
  }
}

// A sheet 16 spawn offsets above the receiver blocks every ray that crosses it. (Where 16 offsets are more than
// a twentieth of the quad, the float spacing at that distance is comparable to the object itself, and the
// configuration is skipped: 1 cm at 1 km.)
TEST_F(SpawnedRays, NeverJumpAnOccluderAFewOffsetsAway) {
  uint32_t seed = 500;
  int tested = 0;
  for (const Config& c : Grid()) {
    std::mt19937 rng(seed++), probeRng = rng;
    // The receiver's error scale, from the same placement without the sheet.
    const Placed probe = PlaceQuad(c, probeRng);
    EmbreeScene probeScene(probe.seq);
    probeScene.Update(probe.state);
    const std::vector<SurfaceHit> probeHits = Receivers(probeScene, probe, c.size, 1, probeRng);
    ASSERT_EQ(probeHits.size(), 1u) << Name(c);
    const float lift = 16.0f * kSpawnRelativeOffset * probeHits[0].errorScale * std::sqrt(3.0f);
    if (lift > 0.05f * c.size) continue;
    ++tested;
    const Placed p = PlaceQuad(c, rng, lift);
    EmbreeScene scene(p.seq);
    scene.Update(p.state);
    int leaks = 0, rays = 0;
    // Receivers on the lower quad: aim from below so the upper sheet does not hide it.
    std::uniform_real_distribution<float> u(-0.5f, 0.5f);
    Vec3 t, b;
    OrthonormalBasis(p.normal, t, b);
    for (int k = 0; k < 40; ++k) {
      const Vec3 target = p.center + c.size * (u(rng) * t + u(rng) * b);
      const Vec3 eye = target - 3.0f * c.size * AtCosine(p.normal, 0.5f, rng);
      const SurfaceHit h = scene.Intersect(eye, glm::normalize(target - eye), kInf);
      if (!h.hit || h.objectId != 0) continue;
      for (float cosine : {1.0f, 0.7f, 0.3f}) {
        // Rays towards the sheet (the side away from the eye), crossing it well inside its extent.
        const Vec3 w = AtCosine(-h.geometricNormal, cosine, rng);
        const Vec3 org = OffsetRayOrigin(h.position, h.geometricNormal, h.errorScale, w);
        leaks += !scene.Occluded(org, w, 0.3f * c.size);
        ++rays;
      }
    }
    EXPECT_GT(rays, 60) << Name(c);
    EXPECT_EQ(leaks, 0) << Name(c) << ": sheet " << lift << " above";
  }
  std::printf("occluder configurations tested: %d of %zu\n", tested, Grid().size());
  EXPECT_GE(tested, 25);
}

}  // namespace spawned_ray_test
}  // namespace restir
