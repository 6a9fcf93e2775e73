// The reference's indirect light (issue 41; sim/reference/reference_paths.h) against closed forms that share
// none of its code: every truth here is computed in double from the scene's description (Lambert's polygon
// formula written out below, the sun disc's irradiance π L sin²α cos θ, the integrating sphere's uniform
// interreflection).
//
// a. A floor that a low sun cannot see, facing a wall that the sun lights whole: with one bounce the floor
//    reflects ρ_f/π · L_w · ∫_wall cos θ dω, L_w = ρ_w/π · π L_sun sin²α cos θ_w the wall's radiance
//    (Lambert's formula for the wall's polygon from the floor point). Two bounces add nothing (a path
//    floor → wall → floor ends on a floor the sun does not reach; the wall cannot see itself), so bounces = 2
//    must give the same; 0 gives a black floor. Every floor pixel sees the wall under at least 6% of π; at
//    1024 samples a pixel each gets at least the allocation's uniform share, 252 paths, which all miss the
//    wall (no spread, a failed assertion) with probability 0.94^252 = 2e-7.
// b. The integrating sphere: inside a closed diffuse sphere (albedo ρ, area A) a small one-sided emitter of
//    area a and radiance L_e sends its whole flux Φ = π a L_e onto the wall; the form factor between two
//    points of a sphere is dA / A whatever their positions, so the light reflected once gives every point the
//    same irradiance ρ Φ / A, and each further reflection multiplies it by ρ. With b bounces a wall point
//    reflects ρ/π (E_direct + ρ Φ / A (1 + ρ + … + ρ^(b−1))), E_direct = L_e ∫_emitter cos θ dω. The sphere is
//    a polyhedron of 128 × 64 segments, whose interreflection differs from a sphere's by about the squared
//    facet angle (3e-4 relative); the emitter hides about a / A of the wall (5e-5). Configurations: at the
//    origin and 1000 m out, the emitter level and tilted, ρ 0.5 and 0.8, bounces 1 to 3; and three emitters
//    of different radiance facing different ways (the sum of their direct light and fluxes), where a path's
//    vertex chooses among lights.
// a'. The same under a constant environment too (one bounce): the sky lights the floor directly, and the wall
//    where the floor does not hide it; an independent midpoint rule over the wall, checked for convergence.
// c. A preset frame's indirect pass (IndirectImage, one path a pixel) over many seeds, against a, a' and b.
// d. ReSTIR GI's frames (sim/estimator/pipeline.h Pipeline::RenderIndirect) of the unbiased GI presets, after
//    temporal and spatial reuse of the paths' vertices, against a and b (GiFramesAverageToTheClosedForms).
//
// Statistics (ExpectAgreement): over the surface pixels compared (pixels independent), the mean relative
// error is 0 by a z-test, and at most kMaxRelativeError with its own standard error below a third of that;
// the squared errors match the reference's standard errors (the mean of e² − se² / t² is 0) by a z-test; each
// z-test at false-failure rate kClaimRate = 1e-4. 16 configurations × 2 z-tests: family rate at most 0.32%.
// Seeds are fixed, so the outcome is deterministic.
#include "sim/reference/reference_paths.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/light_sampler.h"
#include "sim/estimator/pipeline.h"
#include "sim/estimator/presets.h"
#include "sim/reference/reference.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/scene/shapes.h"
#include "sim/scene/sky_frame.h"
#include "stats.h"
#include "tests/sim/reference/closed_form_support.h"
#include "tests/sim/scene_fixtures.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace reference_paths_test {

using namespace closed_form;  // NOLINT: the claims and renderers every section here uses

// ---- a. A sunlit wall seen from a floor in the shade ----

struct WallScene {
  Sequence seq;
  FrameState state;
  std::vector<D3> wall;   // the wall's corners
  std::vector<D3> floor;  // the floor's corners
  double wallRadiance = 0.0;  // what the sun gives it
  double wallAlbedo = 0.0, floorAlbedo = 0.0;
  double environment = 0.0;  // a constant environment's radiance (0: none)
  int32_t floorObject = 0;
};

// The wall: x = 0, facing +x, y in [0.3, 2.8], z in [-2, 2]; the floor: y = 0, x in [0.05, 3], z in
// [-1.5, 1.5], at the wall's foot; the sun 3° below the floor's horizon from +x, so it lights the wall at cos
// θ = cos 3° and never the floor, and its rays from the wall's lowest edge meet the floor's plane 5.7 m out,
// beyond the floor. Everything moved by `offset`. With `environment` > 0, a constant environment of that radiance
// too (a 1×1 map).
WallScene SunlitWall(const D3& offset, double floorAlbedo, double wallAlbedo, double environment = 0.0) {
  WallScene s;
  Sequence& seq = s.seq;
  seq.name = "sunlit_wall";
  seq.width = 64;
  seq.height = 48;
  seq.frameCount = 1;
  seq.contentHash =
      "reference-paths-sunlit-wall-" + std::to_string(offset.x) + "-" + std::to_string(floorAlbedo);
  Material floor, wall;
  floor.name = "floor";
  floor.albedo = Vec3(static_cast<float>(floorAlbedo));
  wall.name = "wall";
  wall.albedo = Vec3(static_cast<float>(wallAlbedo));
  seq.materials = {floor, wall};
  const D3 floorCentre = offset + D3(1.525, 0.0, 0.0), wallCentre = offset + D3(0.0, 1.55, 0.0);
  test::AddQuadObject(seq, "floor", 0, Vec3(floorCentre), Vec3(1.475f, 0.0f, 0.0f), Vec3(0.0f, 0.0f, 1.5f));
  test::AddQuadObject(seq, "wall", 1, Vec3(wallCentre), Vec3(0.0f, 1.25f, 0.0f), Vec3(0.0f, 0.0f, 2.0f));
  s.floorObject = 0;
  for (const D3& c : {D3(0, -1.25, -2), D3(0, 1.25, -2), D3(0, 1.25, 2), D3(0, -1.25, 2)})
    s.wall.push_back(wallCentre + c);
  for (const D3& c : {D3(-1.475, 0, -1.5), D3(1.475, 0, -1.5), D3(1.475, 0, 1.5), D3(-1.475, 0, 1.5)})
    s.floor.push_back(floorCentre + c);
  if (environment > 0.0) {
    seq.contentHash += "-environment-" + std::to_string(environment);
    seq.environment.present = true;
    seq.environment.map.width = 1;
    seq.environment.map.height = 1;
    seq.environment.map.texels = {Vec3(static_cast<float>(environment))};
    seq.environment.keys.push_back(EnvironmentKey{});
    PrepareEnvironment(seq.environment);
  }
  const double sunRadiance = 2.0e4, diameter = 0.53;
  seq.sun.present = true;
  seq.sun.radiance = Vec3(static_cast<float>(sunRadiance));
  seq.sun.angularDiameterDegrees = static_cast<float>(diameter);
  seq.sun.keys.push_back(SunKey{});
  CameraKey k;
  k.position = Vec3(floorCentre + D3(2.0, 2.2, 1.2));
  k.lookAt = Vec3(floorCentre);
  k.vfovDegrees = 50.0f;
  seq.cameraKeys.push_back(k);
  s.state = test::StaticState(seq);
  const double e = Radians(3.0);
  s.state.sunDirection = Vec3(static_cast<float>(std::cos(e)), static_cast<float>(-std::sin(e)), 0.0f);
  s.state.sunIntensity = 1.0f;
  s.state.environmentIntensity = environment > 0.0 ? 1.0f : 0.0f;
  s.environment = environment;
  s.wallAlbedo = wallAlbedo;
  const double sinAlpha = std::sin(Radians(0.5 * diameter));
  s.wallRadiance = wallAlbedo / M_PI * (M_PI * sunRadiance * sinAlpha * sinAlpha * std::cos(e));
  s.floorAlbedo = floorAlbedo;
  return s;
}

double WallTruth(const WallScene& s, const GBuffer& g, size_t i) {
  if (g.objectId[i] != s.floorObject) return std::nan("");
  return s.floorAlbedo / M_PI * s.wallRadiance * ProjectedSolidAngle(D3(g.Position(i)), D3(0, 1, 0), s.wall);
}

// Under a constant environment L as well, with one bounce. The floor sees the sky but where the wall hides it:
// direct ρ_f/π · L (π − ∫_wall cos θ dω). A wall point y sees the sky but where the floor hides it, so its
// radiance is ρ_w/π (E_sun + L (π − ∫_floor cos θ dω)); the floor reflects ρ_f/π ∫_wall L_w(y) cos θ_x cos θ_y / d²
// dA_y of it, the sun's part by Lambert's formula and the environment's by a midpoint rule over the wall (n × n
// cells, each wall point's floor by Lambert's formula). `indirectOnly`: without the floor's direct light.
double EnvironmentWallTruth(const WallScene& s, const D3& x, int n, bool indirectOnly) {
  const D3 up(0, 1, 0), wallNormal(1, 0, 0);
  const double wallPsa = ProjectedSolidAngle(x, up, s.wall);
  const D3 corner = s.wall[0], along = s.wall[1] - s.wall[0], across = s.wall[3] - s.wall[0];
  const double cell = glm::length(along) * glm::length(across) / double(n * n);
  double hidden = 0.0;  // ∫_wall ∫_floor(y) cos dω · cos θ_x cos θ_y / d² dA_y
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const D3 y = corner + ((a + 0.5) / n) * along + ((b + 0.5) / n) * across;
      const D3 d = y - x;
      const double d2 = glm::dot(d, d);
      const double kernel = glm::dot(up, d) * glm::dot(wallNormal, -d) / (d2 * d2);
      hidden += ProjectedSolidAngle(y, wallNormal, s.floor) * kernel * cell;
    }
  const double sunPart = s.wallRadiance * wallPsa;
  const double environmentPart = s.wallAlbedo / M_PI * s.environment * (M_PI * wallPsa - hidden);
  const double direct = indirectOnly ? 0.0 : s.environment * (M_PI - wallPsa);
  return s.floorAlbedo / M_PI * (direct + sunPart + environmentPart);
}

// The truths at every floor pixel by the midpoint rule at 96 cells a side, checked at every 97th pixel against 48
// cells: the two must agree to 1e-4 (relative; the rule's error at 96 is about a third of that, as it falls with the
// cell's area), far below what the claims resolve (the mean relative error's standard error, about 0.2%).
std::vector<double> EnvironmentWallTruths(const WallScene& s, const GBuffer& g, bool indirectOnly) {
  std::vector<double> truth(g.Size(), std::nan(""));
  double worst = 0.0;
  for (size_t i = 0; i < g.Size(); ++i) {
    if (!g.IsSurface(i) || g.objectId[i] != s.floorObject) continue;
    const D3 x(g.Position(i));
    truth[i] = EnvironmentWallTruth(s, x, 96, indirectOnly);
    if (i % 97 == 0) worst = std::max(worst, std::fabs(EnvironmentWallTruth(s, x, 48, indirectOnly) / truth[i] - 1));
  }
  EXPECT_LT(worst, 1e-4) << "the midpoint rule over the wall is not converged";
  return truth;
}

TEST(ReferencePaths, SunlitWallLightsTheShadedFloorByOneBounce) {
  for (const D3& offset : {D3(0.0), D3(600.0, 300.0, -750.0)}) {
    for (int bounces : {1, 2}) {
      const WallScene s = SunlitWall(offset, 0.7, 0.6);
      const Rendered r = Render(s.seq, s.state, bounces, 1024);
      char what[96];
      std::snprintf(what, sizeof what, "sunlit wall, %g m out, %d bounce%s", glm::length(offset), bounces,
                    bounces > 1 ? "s" : "");
      ExpectAgreement(
          r, [&](size_t i) { return WallTruth(s, r.g, i); }, what, 800);
    }
  }
}

TEST(ReferencePaths, UnderAnEnvironmentTheWallReflectsSunAndSkyOntoTheFloor) {
  const WallScene s = SunlitWall(D3(0.0), 0.7, 0.6, 0.2);
  const Rendered r = Render(s.seq, s.state, 1, 1024);
  const std::vector<double> truth = EnvironmentWallTruths(s, r.g, false);
  ExpectAgreement(r, [&](size_t i) { return truth[i]; }, "sunlit wall under a constant environment, 1 bounce", 800);
}

TEST(ReferencePaths, NoBouncesLeavesTheShadedFloorBlack) {
  const WallScene s = SunlitWall(D3(0.0), 0.7, 0.6);
  const Rendered r = Render(s.seq, s.state, 0, 64);
  size_t floor = 0;
  for (size_t i = 0; i < r.g.Size(); ++i)
    if (r.g.IsSurface(i) && r.g.objectId[i] == s.floorObject) {
      ++floor;
      EXPECT_EQ(Y(D3(r.ref.mean.pixels[i])), 0.0) << "pixel " << i;
    }
  EXPECT_GT(floor, 800u);
  EXPECT_EQ(r.ref.paths, 0u);
}

// ---- b. The integrating sphere ----

// A one-sided square emitter as the scene holds it (its corners in float: 1000 m out their rounding, 6e-5 m,
// changes a 4 cm emitter's area by 0.3%, which its flux must follow).
struct SphereEmitter {
  std::vector<D3> corners;  // counter-clockwise seen from its lit side
  D3 normal{0.0};
  double radiance = 0.0, area = 0.0;
};

struct SphereScene {
  Sequence seq;
  FrameState state;
  std::vector<SphereEmitter> emitters;
  double albedo = 0.0, area = 0.0;
  D3 centre{0.0};
};

// Adds a square emitter of half-size h at c, emitting along unit n.
void AddSquareEmitter(SphereScene& s, const D3& c, const D3& n, double h, double radiance) {
  const D3 t1 = glm::normalize(glm::cross(n, std::fabs(n.z) < 0.9 ? D3(0, 0, 1) : D3(1, 0, 0)));
  const D3 t2 = glm::cross(n, t1);  // cross(t1, t2) = n: test::AddQuadLight emits along it
  test::AddQuadLight(s.seq, "emitter" + std::to_string(s.emitters.size()), Vec3(c), Vec3(h * t1),
                     Vec3(h * t2), Vec3(static_cast<float>(radiance)));
  const std::vector<Vec3>& v = s.seq.lights.back().vertices;  // p0 p1 p2, p0 p2 p3
  SphereEmitter e;
  e.corners = {D3(v[0]), D3(v[1]), D3(v[2]), D3(v[5])};
  for (size_t k = 0; k < v.size(); k += 3)
    e.area += 0.5 * glm::length(glm::cross(D3(v[k + 1]) - D3(v[k]), D3(v[k + 2]) - D3(v[k])));
  e.normal = n;
  e.radiance = radiance;
  s.emitters.push_back(e);
}

// One 4 cm emitter 0.2 m below the centre, its normal tilted from +Y about +Z; or three 3 cm emitters of
// different radiance around a small circle, each facing outwards and 30° up, so that each of the others lies
// behind its plane (none shades another's light).
SphereScene IntegratingSphere(const D3& centre, double albedo, double tiltDegrees, int emitters = 1) {
  SphereScene s;
  Sequence& seq = s.seq;
  seq.name = "integrating_sphere";
  seq.width = 48;
  seq.height = 36;
  seq.frameCount = 1;
  seq.contentHash = "reference-paths-sphere-" + std::to_string(centre.x) + "-" + std::to_string(albedo) +
                    "-" + std::to_string(tiltDegrees) + "-" + std::to_string(emitters);
  Material wall;
  wall.name = "wall";
  wall.albedo = Vec3(static_cast<float>(albedo));
  seq.materials = {wall};
  const double radius = 1.0;
  Object sphere;
  sphere.name = "sphere";
  sphere.material = 0;
  sphere.mesh = MakeSphere(Vec3(centre), static_cast<float>(radius), 128);
  sphere.keys.push_back(TransformKey{});
  seq.objects.push_back(sphere);
  // The polyhedron's own area, which its flux spreads over.
  for (const glm::uvec3& t : sphere.mesh.triangles) {
    const D3 a(sphere.mesh.positions[t.x]), b(sphere.mesh.positions[t.y]), c(sphere.mesh.positions[t.z]);
    s.area += 0.5 * glm::length(glm::cross(b - a, c - a));
  }
  if (emitters == 1) {
    const double t = Radians(tiltDegrees);
    AddSquareEmitter(s, centre + D3(0.0, -0.2, 0.0), D3(-std::sin(t), std::cos(t), 0.0), 0.02, 50.0);
  } else {
    const double radiances[3] = {50.0, 20.0, 120.0};
    for (int k = 0; k < 3; ++k) {
      const double phi = 2.0 * M_PI * k / 3.0 + Radians(tiltDegrees);
      const D3 out(std::cos(phi), 0.0, std::sin(phi));
      AddSquareEmitter(s, centre + D3(0.0, -0.1, 0.0) + 0.25 * out,
                       glm::normalize(out + std::tan(Radians(30.0)) * D3(0, 1, 0)), 0.015, radiances[k]);
    }
  }
  s.albedo = albedo;
  s.centre = centre;
  CameraKey k;
  k.position = Vec3(centre + D3(0.3, 0.35, 0.55));
  k.lookAt = Vec3(centre + D3(-0.4, 0.1, -1.0));
  k.vfovDegrees = 70.0f;
  seq.cameraKeys.push_back(k);
  s.state = test::StaticState(seq);
  return s;
}

double SphereTruth(const SphereScene& s, const GBuffer& g, size_t i, int bounces) {
  if (g.objectId[i] != 0) return std::nan("");
  const D3 x(g.Position(i));
  const D3 n = glm::normalize(s.centre - x);  // the wall faces the centre
  double direct = 0.0, flux = 0.0;
  for (const SphereEmitter& e : s.emitters) {
    if (glm::dot(e.normal, x - e.corners[0]) > 0.0)
      direct += e.radiance * ProjectedSolidAngle(x, n, e.corners);
    flux += M_PI * e.area * e.radiance;
  }
  double series = 0.0, power = 1.0;
  for (int k = 0; k < bounces; ++k, power *= s.albedo) series += power;
  return s.albedo / M_PI * (direct + s.albedo * flux / s.area * series);
}

TEST(ReferencePaths, IntegratingSphereReflectsTheGeometricSeries) {
  struct Case {
    D3 centre;
    double albedo, tilt;
    int bounces, emitters;
  };
  const D3 far = 1000.0 * glm::normalize(D3(0.8, 0.36, -0.48));
  for (const Case& c :
       {Case{D3(0.0), 0.8, 0.0, 1, 1}, Case{D3(0.0), 0.8, 0.0, 3, 1}, Case{D3(0.0), 0.5, 35.0, 2, 1},
        Case{far, 0.8, 35.0, 3, 1}, Case{far, 0.5, 0.0, 1, 1}, Case{D3(0.0), 0.8, 80.0, 2, 1},
        Case{D3(0.0), 0.8, 10.0, 2, 3}, Case{far, 0.5, 50.0, 3, 3}}) {
    const SphereScene s = IntegratingSphere(c.centre, c.albedo, c.tilt, c.emitters);
    const Rendered r = Render(s.seq, s.state, c.bounces, 256);
    char what[112];
    std::snprintf(what, sizeof what, "sphere %g m out, albedo %.1f, %d emitter%s, tilt %g, %d bounce%s",
                  glm::length(c.centre), c.albedo, c.emitters, c.emitters > 1 ? "s" : "", c.tilt, c.bounces,
                  c.bounces > 1 ? "s" : "");
    ExpectAgreement(
        r, [&](size_t i) { return SphereTruth(s, r.g, i, c.bounces); }, what, 1500);
  }
}

// ---- c. A preset frame's indirect light (IndirectImage: one path a pixel) ----

// The mean of kSeeds frames' indirect images (seeds 0..kSeeds−1) with its standard error from their spread,
// as a Rendered whose reference is that mean: the claims of ExpectAgreement then hold the frames' estimate
// unbiased and their spread honest (the mean's variance over the seeds, unbiased, as the replicates' is).
Rendered IndirectFrames(const Sequence& seq, const FrameState& state, int bounces, int seeds) {
  Rendered r;
  EmbreeScene scene(seq);
  scene.Update(state);
  TracePrimary(scene, state.camera, r.g);
  const size_t n = r.g.Size();
  std::vector<D3> sum(n, D3(0.0));
  std::vector<double> sumY(n, 0.0), sumYSq(n, 0.0);
  uint64_t rays = 0;
  for (int k = 0; k < seeds; ++k) {
    const ImageRgb image = IndirectImage(seq, state, scene, r.g, bounces, static_cast<uint32_t>(k), 0, rays);
    for (size_t i = 0; i < n; ++i) {
      const D3 v(image.pixels[i]);
      sum[i] += v;
      sumY[i] += Y(v);
      sumYSq[i] += Y(v) * Y(v);
    }
  }
  r.ref.mean = ImageRgb(r.g.width, r.g.height);
  r.ref.lumaStandardError.assign(n, 0.0f);
  for (size_t i = 0; i < n; ++i) {
    r.ref.mean.pixels[i] = Vec3(sum[i] / double(seeds));
    const double meanY = sumY[i] / seeds;
    const double var = std::max(0.0, (sumYSq[i] - seeds * meanY * meanY) / (seeds - 1));
    r.ref.lumaStandardError[i] = static_cast<float>(std::sqrt(var / seeds));
  }
  r.ref.paths = static_cast<uint64_t>(seeds) * n;
  return r;
}

TEST(IndirectImage, FramesAverageToTheClosedForms) {
  {
    // A floor pixel's one path meets the wall with probability 6-32%: 384 frames for a 1% bound with power.
    const WallScene s = SunlitWall(D3(0.0), 0.7, 0.6);
    const Rendered r = IndirectFrames(s.seq, s.state, 1, 384);
    ExpectAgreement(
        r, [&](size_t i) { return WallTruth(s, r.g, i); }, "frames: sunlit wall, 1 bounce", 800);
  }
  {
    const WallScene s = SunlitWall(D3(0.0), 0.7, 0.6, 0.2);
    const Rendered r = IndirectFrames(s.seq, s.state, 1, 512);
    const std::vector<double> truth = EnvironmentWallTruths(s, r.g, true);
    ExpectAgreement(r, [&](size_t i) { return truth[i]; }, "frames: sunlit wall under an environment, 1 bounce", 800);
  }
  {
    // Only the indirect part: the frames' direct light is the presets' (their own tests).
    const SphereScene s = IntegratingSphere(D3(0.0), 0.8, 35.0);
    const Rendered r = IndirectFrames(s.seq, s.state, 3, 96);
    ExpectAgreement(
        r, [&](size_t i) { return SphereTruth(s, r.g, i, 3) - SphereTruth(s, r.g, i, 0); },
        "frames: sphere, albedo 0.8, tilt 35, 3 bounces", 1500);
  }
}

TEST(IndirectImage, SeedsAndFramesGiveIndependentPathsAndNoBouncesNoLight) {
  const WallScene s = SunlitWall(D3(0.0), 0.7, 0.6);
  EmbreeScene scene(s.seq);
  scene.Update(s.state);
  GBuffer g;
  TracePrimary(scene, s.state.camera, g);
  uint64_t rays = 0;
  const ImageRgb a = IndirectImage(s.seq, s.state, scene, g, 1, 7, 0, rays);
  const uint64_t raysOne = rays;
  EXPECT_GT(raysOne, g.Size() / 2);
  const ImageRgb again = IndirectImage(s.seq, s.state, scene, g, 1, 7, 0, rays);
  const ImageRgb otherSeed = IndirectImage(s.seq, s.state, scene, g, 1, 8, 0, rays);
  const ImageRgb otherFrame = IndirectImage(s.seq, s.state, scene, g, 1, 7, 1, rays);
  size_t differSeed = 0, differFrame = 0, lit = 0;
  for (size_t i = 0; i < g.Size(); ++i) {
    EXPECT_EQ(a.pixels[i], again.pixels[i]) << "pixel " << i;
    lit += Y(D3(a.pixels[i])) > 0.0;
    differSeed += a.pixels[i] != otherSeed.pixels[i];
    differFrame += a.pixels[i] != otherFrame.pixels[i];
  }
  EXPECT_GT(lit, 100u);
  EXPECT_GT(differSeed, lit / 2);
  EXPECT_GT(differFrame, lit / 2);
  rays = 0;
  const ImageRgb none = IndirectImage(s.seq, s.state, scene, g, 0, 7, 0, rays);
  EXPECT_EQ(rays, 0u);
  for (const Vec3& p : none.pixels) EXPECT_EQ(p, Vec3(0.0f));
}


TEST(IndirectReuse, GiFramesAverageToTheClosedForms) {
  // 96 seeds: the frames' mean relative error has a standard error of 0.3-0.5% on the floor, 0.15-0.2% on the
  // sphere. This test found the paths' spawn-offset bias (PathScene::Step): before a step was weighed from the
  // ray's true origin, the paths alone read +0.41% (se 0.13%, 400 seeds) 1 km out and +3.0% 10 km out; after,
  // -0.19% and -0.89% (at the origin -0.17%, the same seeds).
  constexpr int kGiSeeds = 96;
  for (const char* name : {"restir-gi-unbiased", "restir-gi-spmis"}) {
    const PipelineSettings& settings = FindPreset(name)->settings;
    {
      const WallScene s = SunlitWall(1000.0 * glm::normalize(D3(-0.3, 0.2, 0.9)), 0.7, 0.6);
      GBuffer g;
      const std::vector<ImageRgb> frames = GiFrames(s.seq, s.state, settings, 4, kGiSeeds, g);
      ExpectUnbiasedFrames(frames, g, [&](size_t i) { return WallTruth(s, g, i); },
                           std::string(name) + ": sunlit wall 1 km out, frame 4");
    }
    {
      // Flat-shaded, as the closed form's polyhedron is (interpolated normals are the tilted-wall test's).
      SphereScene s = IntegratingSphere(1000.0 * glm::normalize(D3(0.8, 0.36, -0.48)), 0.8, 35.0);
      s.seq.objects[0].mesh.normals.clear();
      GBuffer g;
      const std::vector<ImageRgb> frames = GiFrames(s.seq, s.state, settings, 4, kGiSeeds, g);
      ExpectUnbiasedFrames(
          frames, g, [&](size_t i) { return SphereTruth(s, g, i, 1) - SphereTruth(s, g, i, 0); },
          std::string(name) + ": sphere 1 km out, tilt 35, frame 4");
    }
  }
}

// Paired with the paths: per seed, the mean of frames [4, 8) of the GI preset against the mean of the same frames'
// paths without reuse (IndirectImage, the same random numbers), so that most of the paths' noise cancels and a bias
// of reuse alone shows at a few tenths of a percent. Per seed, the mean difference over the compared pixels, and
// over each of four bands of them, relative to the paths' mean over the seeds there; each 0 by Student's t-test
// over the seeds at kClaimRate / 5 (Bonferroni over the five).
void ExpectGiMatchesItsPaths(const Sequence& seq, const FrameState& state, const PipelineSettings& settings,
                             int seeds, const std::function<bool(const GBuffer&, size_t)>& compared,
                             const std::string& what) {
  constexpr int kFrames = 8, kFirst = 4;
  const StaticGiScene s(seq, state);
  const GBuffer& g = s.g;
  std::vector<size_t> pixels;
  for (size_t i = 0; i < g.Size(); ++i)
    if (g.IsSurface(i) && compared(g, i)) pixels.push_back(i);
  ASSERT_GE(pixels.size(), 400u) << what;
  constexpr int kBands = 4;
  std::vector<std::vector<double>> diff(kBands + 1), base(kBands + 1);
  for (int k = 0; k < seeds; ++k) {
    Pipeline pipeline(settings);
    std::vector<double> gi(g.Size(), 0.0), paths(g.Size(), 0.0);
    for (int f = 0; f < kFrames; ++f) {
      const ImageRgb frame = s.Frame(pipeline, k, f);
      if (f < kFirst) continue;
      uint64_t rays = 0;
      const ImageRgb plain = IndirectImage(seq, state, s.scene, g, settings.indirect.bounces,
                                           static_cast<uint32_t>(k), static_cast<uint32_t>(f), rays);
      for (size_t i : pixels) {
        gi[i] += Y(D3(frame.pixels[i]));
        paths[i] += Y(D3(plain.pixels[i]));
      }
    }
    for (int band = -1; band < kBands; ++band) {
      const size_t begin = band < 0 ? 0 : pixels.size() * band / kBands;
      const size_t end = band < 0 ? pixels.size() : pixels.size() * (band + 1) / kBands;
      double d = 0.0, b = 0.0;
      for (size_t j = begin; j < end; ++j) d += gi[pixels[j]] - paths[pixels[j]], b += paths[pixels[j]];
      diff[band + 1].push_back(d);
      base[band + 1].push_back(b);
    }
  }
  const double n = double(seeds);
  for (int band = -1; band < kBands; ++band) {
    double sum = 0.0, sumSq = 0.0, scale = 0.0;
    for (int k = 0; k < seeds; ++k) sum += diff[band + 1][k], sumSq += diff[band + 1][k] * diff[band + 1][k];
    for (double b : base[band + 1]) scale += b / n;
    const double mean = sum / n, se = std::sqrt(std::max(0.0, (sumSq - n * mean * mean) / (n - 1.0)) / n);
    const double q = test::StudentTQuantileTwoSided(kClaimRate / (kBands + 1), n - 1.0);
    std::printf("  %-60s band %2d  GI - paths %+.3f%% (se %.3f%%)\n", what.c_str(), band, 100.0 * mean / scale,
                100.0 * se / scale);
    EXPECT_LE(std::fabs(mean), q * se) << what << " band " << band << ": GI against its paths, t-test";
  }
}

// The wall of the sunlit-wall scene with vertex normals tilted 60° about the vertical: its shading hemisphere
// excludes part of the floor that its geometric one admits, which a vertex's L_o must respect (core/
// reconnection_shift.h InFrontOfVertex). Without it, reconnecting such vertices read +28% near the wall, +15% in the
// middle and -8.5% far from it (t = +23, +15, -18; a review's measurement). (On the plain wall the pairing does not
// help: GI and its paths correlate little, and the closed-form test resolves more.)
TEST(IndirectReuse, GiFramesMatchTheirOwnPathsWhereShadingNormalsTilt) {
  for (const char* name : {"restir-gi-unbiased", "restir-gi-spmis"}) {
    const PipelineSettings& settings = FindPreset(name)->settings;
    WallScene tilted = SunlitWall(D3(0.0), 0.7, 0.6);
    const float t = static_cast<float>(Radians(60.0));
    tilted.seq.objects[1].mesh.normals.assign(4, Vec3(std::cos(t), 0.0f, std::sin(t)));
    const auto floor = [&](const GBuffer& g, size_t i) { return g.objectId[i] == tilted.floorObject; };
    ExpectGiMatchesItsPaths(tilted.seq, tilted.state, settings, 24, floor,
                            std::string(name) + ": wall normals tilted 60 deg");
  }
}

// A glossy x₂ is not reconnected (core/reconnection_shift.h Reconnectable): with a glossy wall every floor path
// goes to the unshifted image, the reservoirs stay empty, and the frame is the paths' own estimate, IndirectImage's
// (the same random numbers; the products in another order, so equal to rounding).
TEST(IndirectReuse, AGlossyVertexIsUsedAtItsOwnPixelOnly) {
  WallScene s = SunlitWall(D3(0.0), 0.7, 0.6);
  s.seq.materials[1].type = MaterialType::kLayered;
  s.seq.materials[1].metallic = 0.3f;
  s.seq.materials[1].roughness = 0.4f;
  ASSERT_FALSE(Reconnectable(MaterialBsdfs(s.seq)[1]));
  GBuffer g;
  const std::vector<ImageRgb> frames =
      GiFrames(s.seq, s.state, FindPreset("restir-gi-unbiased")->settings, 1, 1, g);
  EmbreeScene scene(s.seq);
  scene.Update(s.state);
  uint64_t rays = 0;
  const ImageRgb paths = IndirectImage(s.seq, s.state, scene, g, 1, 0, 0, rays);
  size_t lit = 0;
  for (size_t i = 0; i < g.Size(); ++i) {
    const Vec3 a = frames[0].pixels[i], b = paths.pixels[i];
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 1e-5f * b[c]) << "pixel " << i;
    lit += Y(D3(b)) > 0.0;
  }
  EXPECT_GT(lit, 100u);
}

}  // namespace reference_paths_test
}  // namespace restir
