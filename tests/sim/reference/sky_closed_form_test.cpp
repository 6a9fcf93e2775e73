// The reference under sun and sky (issue 18) against closed forms and independent quadratures, none of which
// calls core/sky or the reference's samplers: every truth here is computed in double from the scene's
// description (the map's lat-long layout as core/sky.h documents it, the sun's cone, the occluder's edge).
//
// a. Furnace: a constant environment L (a 1×1 map, at several intensities and rotations) over an unoccluded
//    diffuse plane reflects albedo·L exactly, whatever the plane's tilt (a tilted plane sees part of the lower
//    hemisphere, which is sky too). Pixels whose primary ray escapes show L itself, bit for bit, with no error.
// b. One-texel maps: black but for texel (c, r) of radiance L. A diffuse plane of normal n reflects
//    albedo/π · L · ∫_texel max(0, n·ω) dω; for n = +Y and a texel above the horizon the integral is
//    Δφ (sin²λ_top − sin²λ_bottom) / 2, Δφ = 2π / width; otherwise a 2-D midpoint quadrature over the texel in
//    (longitude, sin latitude) (uniform in solid angle), itself checked against the closed form. The map's
//    rotation ρ about +Y adds ρ to every longitude (atan2(x, z)).
// c. Sun disc (half-angle α) above the horizon: irradiance E = π L sin²α cos θ, θ the centre's angle from the
//    normal; reflected albedo/π · E, for diameters 0.53°, 5°, 20° and elevations 90° down to just above α.
// d. Sun behind a straight edge (an opaque quad, a roof or a wall, whose edge crosses the disc seen from the
//    receiver), diameters 0.53°, 5°, 20°: the visible part of the disc is its intersection with the hemisphere
//    bounded by the plane through the receiver and the edge line, so the truth is ∫ over the cone of n·ω on that
//    side: per ring of the cone (angle t from its centre) the visible arc and the integral of n·ω over it are
//    closed forms, and the rings are summed by a fine midpoint rule in t. The test checks, per pixel, that the
//    quad's other edges are out of the cone's way. Visibility is that of the segment spawned off the receiver
//    (core/shadow_ray.h: a lift of 16 × 2^-24 of the receiver's error scale), which is measurable 1000 m from the
//    origin (0.8 mm there moves the 20° sun's penumbra by 0.3%); the comparison against the unlifted point is
//    printed. Only pixels where neither the visible nor the hidden part of the disc is a sliver (under 10%) take
//    the z claims (see the test); the others are held within 10% of the unoccluded value.
// e. GGX and layered planes under a constant environment: reflected L × the BSDF's directional albedo, by a
//    quadrature over half vectors written here (D, height-correlated Smith G2, Schlick Fresnel in double),
//    checked for convergence.
// f. The whole mixture at once: a quad light, a sun and a constant environment over a diffuse plane; the quad
//    light hides its own solid angle of the sky: truth albedo/π (E_light + E_sun + L_env (π − ∫_light cos dω)),
//    Lambert's polygon formula for the light's terms (core/polygon_irradiance.h, as tests/sim/closed_form_test).
//
// The grid moves receivers 100 m and 1000 m from the origin, tilts them (up to a vertical wall), and uses tiny
// (1 cm) and huge (10 km) quads.
//
// Statistics (tests/sim/reference/closed_form_test.cpp's): per configuration and surface pixel, z = (Y(ref) −
// Y(truth)) / the reference's luminance standard error (16 replicates: Student t, 15 dof; pixels independent).
// Claims, each at false-failure rate kClaimRate = 1e-4: the mean of z² in 15/13 ± q·sqrt(3.389 / pixels) (q the
// two-sided normal quantile); max |z| below the t15 quantile of kClaimRate / pixels (Bonferroni); the mean relative
// error over lit pixels within a z-test of 0 and at most 0.1% (the reference's own standard error of it below 0.033%,
// so the bound can fail; 0.2% and 0.067% for the penumbrae of d). Pixels where every replicate agreed (standard error
// 0) must be exact (only unlit pixels are). Where the sampling noise is below single precision (a sun near a
// receiver's zenith), z's denominator gets a rounding floor and the mean of z² is bounded from above only
// (kRoundingFloor). With 33 configurations × 3 claims the file's family false-failure rate is at most 0.99%; seeds
// are fixed, so the outcome is deterministic. About 12 s on 2 cores.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "core/polygon_irradiance.h"
#include "tests/sim/scene_fixtures.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/reference/reference.h"
#include "sim/scene/sky_frame.h"
#include "stats.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace sky_closed_form_test {

using D3 = glm::dvec3;

constexpr double kClaimRate = 1e-4;
constexpr int kSpp = 1024;
// The reference computes each sample in single precision: a pixel carries a relative rounding error of a few
// 2^-24 that no replicate spread shows, and that is not independent between pixels. Where the sampling noise is
// smaller still (a sun at the zenith over a plane: every sample nearly the same value), z's denominator would
// be that noise alone, so it adds this relative floor in quadrature, and so does the mean relative error's.
constexpr double kRoundingFloor = 2e-6;

double Y(const D3& c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }
double Radians(double degrees) { return degrees * M_PI / 180.0; }

// A receiving plane: unit normal n = (sin τ cos ψ, cos τ, sin τ sin ψ) (tilt τ from +Y towards azimuth ψ), its
// tangents, centre and half-size.
struct Plane {
  D3 centre{0.0};
  double tiltDegrees = 0.0;
  double azimuthDegrees = 0.0;
  double halfSize = 4.0;
  D3 Normal() const {
    const double t = Radians(tiltDegrees), p = Radians(azimuthDegrees);
    return {std::sin(t) * std::cos(p), std::cos(t), std::sin(t) * std::sin(p)};
  }
  D3 Tangent1() const {  // d n / d τ
    const double t = Radians(tiltDegrees), p = Radians(azimuthDegrees);
    return {std::cos(t) * std::cos(p), -std::sin(t), std::cos(t) * std::sin(p)};
  }
  D3 Tangent2() const {  // horizontal
    const double p = Radians(azimuthDegrees);
    return {-std::sin(p), 0.0, std::cos(p)};
  }
};

// A point `metres` from the origin along a direction with no zero component.
D3 Far(double metres) { return metres * glm::normalize(D3(0.8, 0.36, -0.48)); }

// A sequence with the plane (material `m`), its camera `distance` from the centre on the normal's side (25° off
// it, so the view is never straight down), looking at the centre.
Sequence PlaneScene(const std::string& name, const Plane& p, const Material& m, double distance, double vfov,
                    int width, int height) {
  Sequence seq;
  seq.name = name;
  seq.width = width;
  seq.height = height;
  seq.frameCount = 1;
  seq.contentHash = "sky-closed-form-" + name;
  seq.materials.push_back(m);
  test::AddQuadObject(seq, "plane", 0, Vec3(p.centre), Vec3(p.halfSize * p.Tangent1()),
                      Vec3(p.halfSize * p.Tangent2()));
  const double b = Radians(25.0);
  CameraKey k;
  k.position = Vec3(p.centre + distance * (std::cos(b) * p.Normal() + std::sin(b) * p.Tangent2()));
  k.lookAt = Vec3(p.centre);
  k.vfovDegrees = static_cast<float>(vfov);
  seq.cameraKeys.push_back(k);
  return seq;
}

Material Diffuse(const D3& albedo) {
  Material m;
  m.name = "receiver";
  m.albedo = Vec3(albedo);
  return m;
}

void SetEnvironment(Sequence& seq, int width, int height, const std::vector<Vec3>& texels) {
  seq.environment.present = true;
  seq.environment.map.width = width;
  seq.environment.map.height = height;
  seq.environment.map.texels = texels;
  seq.environment.keys.push_back(EnvironmentKey{});
  PrepareEnvironment(seq.environment);
}

void SetSun(Sequence& seq, const Vec3& radiance, float diameterDegrees) {
  seq.sun.present = true;
  seq.sun.radiance = radiance;
  seq.sun.angularDiameterDegrees = diameterDegrees;
  seq.sun.keys.push_back(SunKey{});
}

// The sky fields of a frame state (the sequence reader's Evaluate sets them in a run).
struct SkyState {
  float environmentIntensity = 0.0f;
  float environmentRotationDegrees = 0.0f;
  Vec3 sunDirection{0.0f, 1.0f, 0.0f};
  float sunIntensity = 0.0f;
};

struct Rendered {
  GBuffer g;
  ReferenceImage ref;
  FrameState state;
};

Rendered Render(const Sequence& seq, const SkyState& sky, int spp = kSpp) {
  Rendered r;
  r.state = test::StaticState(seq);
  r.state.environmentIntensity = sky.environmentIntensity;
  r.state.environmentRotationDegrees = sky.environmentRotationDegrees;
  r.state.sunDirection = sky.sunDirection;
  r.state.sunIntensity = sky.sunIntensity;
  EmbreeScene scene(seq);
  scene.Update(r.state);
  TracePrimary(scene, r.state.camera, r.g);
  ReferenceParams params;
  params.samplesPerPixel = spp;
  r.ref = RenderReference(seq, r.state, scene, r.g, params);
  return r;
}

struct Verdict {
  int pixels = 0;       // surface pixels with a standard error
  int exactPixels = 0;  // surface pixels whose replicates all agreed (each checked to be exact)
  // Pixels whose sampling noise is below 10x the rounding floor: their z is shrunk by the floor, so the mean of z²
  // is only bounded from above.
  int roundingLimited = 0;
  double meanZ2 = 0.0, maxAbsZ = 0.0;
  std::string worst;  // the pixel of the largest |z|
  double relativeError = 0.0, relativeStdError = 0.0;
};

// Y(reference) against `truth` (luminance) at every surface pixel `compared` accepts (null: all).
Verdict Compare(const Rendered& r, const std::function<double(size_t)>& truth,
                const std::function<bool(size_t)>& compared = nullptr) {
  Verdict v;
  const GBuffer& g = r.g;
  std::vector<double> exact(g.Size(), 0.0);
  double brightest = 0.0;
  for (size_t i = 0; i < g.Size(); ++i)
    if (g.IsSurface(i)) brightest = std::max(brightest, exact[i] = truth(i));
  double sumRelative = 0.0, sumRelativeVar = 0.0;
  int lit = 0;
  for (size_t i = 0; i < g.Size(); ++i) {
    if (!g.IsSurface(i) || (compared && !compared(i))) continue;
    const double value = Y(D3(r.ref.mean.pixels[i])), se = r.ref.lumaStandardError[i];
    if (exact[i] > 1e-3 * brightest) {
      sumRelative += value / exact[i] - 1.0;
      sumRelativeVar += se * se / (exact[i] * exact[i]);
      ++lit;
    }
    if (se == 0.0) {
      // No spread: no light reaches the pixel, or the difference estimator took its sun as exact (every draw
      // arrived, ReferenceParams::differenceShadows) and nothing else lights it; either way its value is the closed
      // form's, to the rounding floor (the float geometry: a plane 1000 m out is tilted by its vertices' rounding).
      ++v.exactPixels;
      EXPECT_NEAR(value, exact[i], kRoundingFloor * exact[i]) << "pixel " << i << ": no spread";
      continue;
    }
    const double z = (value - exact[i]) / std::hypot(se, kRoundingFloor * exact[i]);
    if (se < 10.0 * kRoundingFloor * exact[i]) ++v.roundingLimited;
    v.meanZ2 += z * z;
    if (std::fabs(z) > v.maxAbsZ) {
      v.maxAbsZ = std::fabs(z);
      char buf[160];
      std::snprintf(buf, sizeof buf, "pixel (%zu, %zu): ref %.7g +- %.2g, truth %.7g", i % g.width, i / g.width,
                    value, se, exact[i]);
      v.worst = buf;
    }
    ++v.pixels;
  }
  v.meanZ2 /= std::max(1, v.pixels);
  v.relativeError = sumRelative / std::max(1, lit);
  v.relativeStdError = std::hypot(std::sqrt(sumRelativeVar) / std::max(1, lit), kRoundingFloor);
  return v;
}

// The three claims, and enough pixels; the mean relative error at most maxRelativeError, and its standard error
// below a third of that.
void ExpectAgreement(const Verdict& v, const std::string& what, int minPixels = 300,
                     double maxRelativeError = 1e-3) {
  const double dof = 15.0;
  const double mean = test::StudentTSquaredMean(dof);
  const double band = test::NormalQuantileUpper(0.5 * kClaimRate) *
                      std::sqrt(test::StudentTSquaredVariance(dof) / std::max(1, v.pixels));
  const double tail = test::StudentTQuantileTwoSided(kClaimRate / std::max(1, v.pixels), dof);
  const double tMean = test::NormalQuantileUpper(0.5 * kClaimRate);
  const bool twoSided = v.roundingLimited == 0;
  char lower[16] = "   0";
  if (twoSided) std::snprintf(lower, sizeof lower, "%.3f", std::sqrt(std::max(0.0, mean - band)));
  std::printf("  %-58s px %4d (+%4d exact)  RMS z %.3f (%s..%.3f)  max|z| %5.2f (<%.2f)  rel.err %+.4f%% "
              "(se %.4f%%)%s\n",
              what.c_str(), v.pixels, v.exactPixels, std::sqrt(v.meanZ2), lower, std::sqrt(mean + band), v.maxAbsZ,
              tail, 100.0 * v.relativeError, 100.0 * v.relativeStdError,
              twoSided ? "" : "  [noise below single precision: RMS bounded above only]");
  // Exact pixels count: each was held to the closed form above.
  EXPECT_GE(v.pixels + v.exactPixels, minPixels) << what;
  EXPECT_LE(v.meanZ2, mean + band) << what << ": RMS z " << std::sqrt(v.meanZ2);
  if (twoSided && v.pixels > 0) {
    EXPECT_GE(v.meanZ2, mean - band) << what << ": RMS z " << std::sqrt(v.meanZ2);
  }
  EXPECT_LE(v.maxAbsZ, tail) << what << ": worst " << v.worst;
  EXPECT_LE(std::fabs(v.relativeError), maxRelativeError) << what << ": mean relative error";
  EXPECT_LE(std::fabs(v.relativeError), tMean * v.relativeStdError) << what << ": mean relative error, z-test";
  EXPECT_LT(v.relativeStdError, maxRelativeError / 3.0) << what << ": the bound on the relative error has no power";
}

// ---------------------------------------------------------------------------------------------------------
// a. Furnace.

struct FurnaceCase {
  std::string name;
  Plane plane;
  double distance = 1.0;  // camera from the plane's centre
  double vfov = 40.0;
  float intensity = 1.0f;
  float rotationDegrees = 0.0f;
};

TEST(SkyClosedForm, ConstantEnvironmentIsAFurnace) {
  const Vec3 colour(1.0f, 0.85f, 0.6f);
  const D3 albedo(0.8, 0.5, 0.3);
  std::vector<FurnaceCase> grid;
  grid.push_back({"horizontal, origin", {}, 1.0});
  grid.push_back({"tilted 35 deg, 1000 m, intensity 2.5", {Far(1000.0), 35.0, 30.0}, 1.0, 40.0, 2.5f});
  grid.push_back({"tilted 80 deg, 100 m, rotated 77 deg", {Far(100.0), 80.0, 200.0}, 1.0, 40.0, 1.0f, 77.0f});
  grid.push_back({"vertical wall facing -z", {D3(0.0), 90.0, 270.0}, 1.0});
  // 1 cm quad, 1000 m from the origin, seen from 2 cm: the view's edges miss it (the sky behind is checked too).
  grid.push_back({"tiny 1 cm, tilted 20 deg, 1000 m", {Far(1000.0), 20.0, 120.0, 0.005}, 0.02, 30.0, 0.5f});
  grid.push_back({"huge 10 km, tilted 60 deg", {D3(0.0), 60.0, 10.0, 5000.0}, 2.0, 40.0});
  for (const FurnaceCase& c : grid) {
    SCOPED_TRACE(c.name);
    Sequence seq = PlaneScene("furnace", c.plane, Diffuse(albedo), c.distance, c.vfov, 32, 32);
    SetEnvironment(seq, 1, 1, {colour});
    const Rendered r = Render(seq, {c.intensity, c.rotationDegrees});
    const double truth = Y(albedo * D3(colour) * double(c.intensity));
    int background = 0;
    for (size_t i = 0; i < r.g.Size(); ++i) {
      if (r.g.IsSurface(i)) continue;
      // The sky behind, exactly: the map's one texel times the intensity, no noise.
      ++background;
      const Vec3 expected = Vec3(c.intensity) * colour;
      EXPECT_EQ(r.ref.mean.pixels[i], expected) << "background pixel " << i;
      EXPECT_EQ(r.ref.lumaStandardError[i], 0.0f) << "background pixel " << i;
    }
    const Verdict v = Compare(r, [&](size_t) { return truth; });
    ExpectAgreement(v, "a. " + c.name + (background ? ", " + std::to_string(background) + " sky px" : ""));
    if (c.name.rfind("tiny", 0) == 0) {
      EXPECT_GT(background, 0);  // the case exists to show the sky behind
    }
  }
}

// ---------------------------------------------------------------------------------------------------------
// b. One-texel maps.

// ∫ over texel (column c, row r) of a width × height lat-long map, rotated ρ about +Y, of max(0, n·ω) dω, by the
// midpoint rule on an N × N grid in (longitude, sin latitude), where dω = dlongitude d(sin latitude). Column 0
// spans longitudes π down to π − 2π/width; row 0 latitudes π/2 down to π/2 − π/height (core/sky.h's layout).
double TexelCosineIntegral(int width, int height, int c, int r, double rotationDegrees, const D3& n, int N) {
  const double lonHi = M_PI - 2.0 * M_PI * c / width, lonLo = M_PI - 2.0 * M_PI * (c + 1) / width;
  const double sHi = std::sin(M_PI / 2 - M_PI * r / height), sLo = std::sin(M_PI / 2 - M_PI * (r + 1) / height);
  const double rho = Radians(rotationDegrees);
  const double dl = (lonHi - lonLo) / N, ds = (sHi - sLo) / N;
  double sum = 0.0;
  for (int a = 0; a < N; ++a) {
    // World longitude = map longitude + ρ.
    const double lon = lonLo + (a + 0.5) * dl + rho;
    const double sl = std::sin(lon), cl = std::cos(lon);
    for (int b = 0; b < N; ++b) {
      const double y = sLo + (b + 0.5) * ds, h = std::sqrt(std::max(0.0, 1.0 - y * y));
      sum += std::max(0.0, n.x * h * sl + n.y * y + n.z * h * cl);
    }
  }
  return sum * dl * ds;
}

struct TexelCase {
  std::string name;
  int width, height, column, row;
  double rotationDegrees;
  Plane plane;
};

TEST(SkyClosedForm, OneTexelMapMatchesTheTexelsCosineIntegral) {
  const D3 albedo(0.7, 0.6, 0.5);
  const Vec3 radiance(40.0f, 30.0f, 20.0f);
  std::vector<TexelCase> grid;
  grid.push_back({"8x4, texel at the pole, horizontal", 8, 4, 3, 0, 0.0, {}});
  grid.push_back({"16x8, texel on the horizon, horizontal, 1000 m", 16, 8, 5, 3, 0.0, {Far(1000.0)}});
  grid.push_back({"16x8, texel on the horizon, rotated 40, tilted 30", 16, 8, 5, 3, 40.0, {D3(0.0), 30.0, 75.0}});
  grid.push_back({"16x8, texel below the horizon, tilted 60", 16, 8, 4, 4, 0.0, {D3(0.0), 60.0, -20.0}});
  grid.push_back({"64x32, small texel, rotated -120, tilted 45, 1000 m", 64, 32, 40, 9, -120.0,
                  {Far(1000.0), 45.0, 160.0}});
  grid.push_back({"32x16, texel near the pole, rotated 200, wall", 32, 16, 7, 1, 200.0, {D3(0.0), 90.0, 100.0}});
  for (const TexelCase& c : grid) {
    SCOPED_TRACE(c.name);
    const D3 n = c.plane.Normal();
    const double integral = TexelCosineIntegral(c.width, c.height, c.column, c.row, c.rotationDegrees, n, 1024);
    if (c.plane.tiltDegrees == 0.0) {
      // The closed form for n = +Y (the texel above the horizon): Δφ (sin²λ_top − sin²λ_bottom) / 2; checks the
      // quadrature itself.
      const double top = M_PI / 2 - M_PI * c.row / c.height, bottom = M_PI / 2 - M_PI * (c.row + 1) / c.height;
      ASSERT_GE(bottom, 0.0);
      const double closed = (2.0 * M_PI / c.width) *
                            (std::sin(top) * std::sin(top) - std::sin(bottom) * std::sin(bottom)) / 2.0;
      std::printf("  b. %s: quadrature %.9g, closed form %.9g\n", c.name.c_str(), integral, closed);
      EXPECT_NEAR(integral, closed, 1e-7 * closed);
    } else {
      // The quadrature converged: a 4x coarser grid agrees to 1e-5.
      const double coarse = TexelCosineIntegral(c.width, c.height, c.column, c.row, c.rotationDegrees, n, 256);
      EXPECT_NEAR(integral, coarse, 1e-5 * integral);
    }
    ASSERT_GT(integral, 0.0);
    Sequence seq = PlaneScene("texel", c.plane, Diffuse(albedo), 1.0, 40.0, 32, 32);
    std::vector<Vec3> texels(static_cast<size_t>(c.width * c.height), Vec3(0.0f));
    texels[static_cast<size_t>(c.row * c.width + c.column)] = radiance;
    SetEnvironment(seq, c.width, c.height, texels);
    const Rendered r = Render(seq, {1.0f, static_cast<float>(c.rotationDegrees)});
    const double truth = Y(albedo * D3(radiance)) / M_PI * integral;
    ExpectAgreement(Compare(r, [&](size_t) { return truth; }), "b. " + c.name);
  }
}

// ---------------------------------------------------------------------------------------------------------
// c. Sun disc above the horizon.

// The direction `elevation` degrees above the plane, towards azimuth `azimuth` (degrees) in its tangent frame.
D3 DirectionAbove(const Plane& p, double elevationDegrees, double azimuthDegrees) {
  const double e = Radians(elevationDegrees), a = Radians(azimuthDegrees);
  return std::sin(e) * p.Normal() + std::cos(e) * (std::cos(a) * p.Tangent1() + std::sin(a) * p.Tangent2());
}

TEST(SkyClosedForm, SunDiscAboveTheHorizonGivesPiLSin2AlphaCosTheta) {
  const D3 albedo(0.6, 0.6, 0.6);
  int index = 0;
  for (const float diameter : {0.53f, 5.0f, 20.0f}) {
    const double alpha = Radians(0.5 * double(diameter));
    // Illuminance 3 at normal incidence whatever the size.
    const float radiance = static_cast<float>(3.0 / (M_PI * std::sin(alpha) * std::sin(alpha)));
    const double justAbove = 0.5 * double(diameter) * 1.1 + 0.01;
    for (const double elevation : {90.0, 45.0, 10.0, justAbove}) {
      // The receiver varies along the grid: horizontal at the origin, tilted 30° 1000 m away, tilted 70° 100 m
      // away on a huge quad, a vertical wall.
      Plane plane;
      std::string where;
      switch ((index + index / 4) % 4) {  // each diameter starts one receiver further on
        case 0: where = "horizontal"; break;
        case 1: plane = {Far(1000.0), 30.0, 45.0}, where = "tilted 30, 1000 m"; break;
        case 2: plane = {Far(100.0), 70.0, 250.0, 5000.0}, where = "tilted 70, 100 m, 10 km quad"; break;
        default: plane = {D3(0.0), 90.0, 10.0}, where = "wall"; break;
      }
      ++index;
      char name[160];
      std::snprintf(name, sizeof name, "sun %.2f deg at %.3f deg, %s", diameter, elevation, where.c_str());
      SCOPED_TRACE(name);
      Sequence seq = PlaneScene("sun", plane, Diffuse(albedo), 1.0, 40.0, 32, 32);
      SetSun(seq, Vec3(radiance), diameter);
      const D3 d = DirectionAbove(plane, elevation, 30.0);
      SkyState sky;
      sky.sunDirection = Vec3(d);
      sky.sunIntensity = 1.0f;
      const Rendered r = Render(seq, sky);
      // E = π L sin²α cos θ; reflected albedo/π E. cos θ from the pixel's own normal, as the renderer holds it: a
      // plane 1000 m out is tilted by its float vertices' rounding by about 1e-6, which moves cos θ by 1e-6 tan θ,
      // 8e-6 relative with the sun 11° up, and the difference estimator's exact pixels show every digit of it.
      const D3 sunDirection = glm::normalize(D3(Vec3(d)));
      const double scale = Y(albedo) * double(radiance) * std::sin(alpha) * std::sin(alpha);
      ExpectAgreement(Compare(r, [&](size_t i) { return scale * glm::dot(sunDirection, D3(r.g.ShadingNormal(i))); }),
                      std::string("c. ") + name);
    }
  }
}

// ---------------------------------------------------------------------------------------------------------
// d. Sun behind a straight edge.

// ∫ over the cone of half-angle α about s, restricted to m·ω > 0, of n·ω dω (n·ω > 0 on the whole cone). A ring
// at angle t from s is ω(φ) = cos t s + sin t (cos φ e1 + sin φ e2): m·ω = A + R cos(φ − φ0) with A = cos t m·s,
// R cos φ0 = sin t m·e1, R sin φ0 = sin t m·e2, visible on φ − φ0 ∈ (−β, β), β = acos(−A / R) (all of it when
// A ≥ R, none when A ≤ −R); n·ω = p + q cos φ + r sin φ integrates over that arc to 2βp + 2 sin β (q cos φ0 +
// r sin φ0). The rings are summed with weight sin t by the midpoint rule on `rings` rings.
// Unit e1, e2 completing the unit s to an orthonormal basis.
void Basis(const D3& s, D3& e1, D3& e2) {
  e1 = glm::normalize(std::fabs(s.x) < 0.9 ? glm::cross(s, D3(1, 0, 0)) : glm::cross(s, D3(0, 1, 0)));
  e2 = glm::cross(s, e1);
}

double VisibleCapCosineIntegral(const D3& s, double alpha, const D3& n, const D3& m, int rings) {
  D3 e1, e2;
  Basis(s, e1, e2);
  const double dt = alpha / rings;
  double sum = 0.0;
  for (int k = 0; k < rings; ++k) {
    const double t = (k + 0.5) * dt, ct = std::cos(t), st = std::sin(t);
    const double a = ct * glm::dot(m, s), rc = st * glm::dot(m, e1), rs = st * glm::dot(m, e2);
    const double radius = std::hypot(rc, rs), phi0 = std::atan2(rs, rc);
    const double beta = a >= radius ? M_PI : a <= -radius ? 0.0 : std::acos(-a / radius);
    const double p = ct * glm::dot(n, s), q = st * glm::dot(n, e1), r = st * glm::dot(n, e2);
    sum += (2.0 * beta * p + 2.0 * std::sin(beta) * (q * std::cos(phi0) + r * std::sin(phi0))) * st;
  }
  return sum * dt;
}

// The occluder is a 4 m × 4 m quad, centre ± u ± v, whose +u side is the occluding edge: large against the
// cone's footprint on it (the test checks that no other side comes near), and no larger, because Embree places
// a triangle's edge only to about 2^-24 of the triangle's size (its hit test works in single precision on the
// vertices relative to the ray origin): 24 µm for a 200 m quad, which moved the 0.53° sun's penumbra here by
// 0.4% (measured while writing this test); 0.5 µm for 4 m.
struct EdgeCase {
  std::string name;
  float diameter;
  D3 sun;             // unit, towards the sun
  D3 origin;          // the receiver (a horizontal plane) and everything else shifted by this
  D3 occluderCentre;  // the occluder quad (before the shift)
  D3 occluderU, occluderV;
  D3 view;            // the floor point the camera looks at (before the shift)
  double cameraDistance;
};

// A roof: a horizontal quad at height h whose edge x = 0 runs along z, covering x < 0; the sun in the x-y plane
// at `elevation`, towards +x. The penumbra on the floor is centred at x = −h cot(elevation).
EdgeCase Roof(const std::string& name, float diameter, double elevation, double h, const D3& origin,
              double cameraDistance) {
  EdgeCase c;
  c.name = name;
  c.diameter = diameter;
  const double e = Radians(elevation);
  c.sun = D3(std::cos(e), std::sin(e), 0.0);
  c.origin = origin;
  c.occluderCentre = D3(-2.0, h, 0.0), c.occluderU = D3(2.0, 0.0, 0.0), c.occluderV = D3(0.0, 0.0, 2.0);
  c.view = D3(-h / std::tan(e), 0.0, 0.0);
  c.cameraDistance = cameraDistance;
  return c;
}

// The penumbra's visibility is a step across the disc: more samples than elsewhere, and a looser bound on the
// mean relative error (whose standard error is larger there).
constexpr int kEdgeSpp = 2048;
constexpr double kEdgeMaxRelativeError = 2e-3;

TEST(SkyClosedForm, SunBehindAStraightEdgeMatchesTheVisibleCap) {
  const D3 albedo(0.5, 0.55, 0.6);
  std::vector<EdgeCase> grid;
  grid.push_back(Roof("5 deg sun at 45 deg under a roof edge 1 m up", 5.0f, 45.0, 1.0, D3(0.0), 0.25));
  grid.push_back(Roof("0.53 deg sun at 30 deg under a roof edge 0.5 m up", 0.53f, 30.0, 0.5, D3(0.0), 0.03));
  grid.push_back(Roof("20 deg sun at 40 deg, roof edge 1 m up, 1000 m", 20.0f, 40.0, 1.0, Far(1000.0), 0.8));
  {
    // A wall: a vertical quad in the plane z = 0 covering x < 0 with its edge x = 0 vertical; the sun low and
    // across it, so the edge's shadow on the floor runs away from the wall.
    EdgeCase c;
    c.name = "5 deg sun at 20 deg past a wall's vertical edge, 100 m";
    c.diameter = 5.0f;
    const double e = Radians(20.0), az = Radians(60.0);
    c.sun = D3(std::cos(e) * std::sin(az), std::sin(e), -std::cos(e) * std::cos(az));
    c.origin = Far(100.0);
    c.occluderCentre = D3(-2.0, 0.0, 0.0), c.occluderU = D3(2.0, 0.0, 0.0), c.occluderV = D3(0.0, 2.0, 0.0);
    // Floor points 0.6 m behind the wall (z > 0) on the edge's shadow line: the ray towards the sun meets z = 0
    // at x + z tan(az), so the line is x = −z tan(az).
    c.view = D3(-0.6 * std::tan(az), 0.0, 0.6);
    c.cameraDistance = 0.35;
    grid.push_back(c);
  }
  for (const EdgeCase& c : grid) {
    SCOPED_TRACE(c.name);
    const double alpha = Radians(0.5 * double(c.diameter));
    const float radiance = static_cast<float>(2.0 / (M_PI * std::sin(alpha) * std::sin(alpha)));
    Plane floor{c.origin + c.view, 0.0, 0.0, 2.0};
    Sequence seq = PlaneScene("edge", floor, Diffuse(albedo), c.cameraDistance, 40.0, 32, 32);
    Material occluder = Diffuse(D3(0.5));
    occluder.name = "occluder";
    seq.materials.push_back(occluder);
    test::AddQuadObject(seq, "occluder", 1, Vec3(c.origin + c.occluderCentre), Vec3(c.occluderU),
                        Vec3(c.occluderV));
    SetSun(seq, Vec3(radiance), c.diameter);
    SkyState sky;
    sky.sunDirection = Vec3(c.sun);
    sky.sunIntensity = 1.0f;
    const Rendered r = Render(seq, sky, kEdgeSpp);
    const D3 s = glm::normalize(D3(Vec3(c.sun))), n(0.0, 1.0, 0.0);
    // The occluding edge as the scene stores it (float corners 1 and 2, c + u ∓ v), not as designed.
    const std::vector<Vec3>& corners = seq.objects[1].mesh.positions;
    const D3 a(corners[1]), b(corners[2]);
    const D3 centre = 0.25 * (D3(corners[0]) + D3(corners[1]) + D3(corners[2]) + D3(corners[3]));
    const D3& inside = centre;
    const D3 qn = glm::normalize(glm::cross(c.occluderU, c.occluderV));
    D3 e1, e2;
    Basis(s, e1, e2);
    // Per pixel: the truth (luminance) and the visible share of the disc's cosine-weighted solid angle.
    std::vector<double> exact(r.g.Size(), 0.0), share(r.g.Size(), 0.0), unlifted(r.g.Size(), 0.0);
    double unoccluded = 0.0;  // the brightest a pixel can be: the whole disc
    for (size_t i = 0; i < r.g.Size(); ++i) {
      if (!r.g.IsSurface(i)) continue;
      const D3 x(r.g.Position(i));
      ASSERT_NEAR(r.g.ShadingNormal(i).y, 1.0f, 1e-6f);  // the floor, seen from above
      // The reference traces visibility from x spawned off the floor (core/shadow_ray.h's rule, restated here):
      // lifted along the geometric normal by 16 units of 2^-24 of the receiver's error scale times ‖n‖₁: 3 µm
      // for the 4 m floor at the origin, 0.8 mm 1000 m away (49 µm for a 100 m floor, which darkened the 0.53°
      // sun's penumbra by 1.7% against the unlifted truth while this test was written). Near a penumbra that is
      // measurable (the shadow's edge moves by lift · cot(elevation)), so the truth is the visibility from the
      // lifted point; the unlifted one is compared as well, and printed.
      const D3 ng(r.g.GeometricNormal(i));
      const double lift = 16.0 * std::ldexp(1.0, -24) * double(r.g.errorScale[i]) *
                          (std::fabs(ng.x) + std::fabs(ng.y) + std::fabs(ng.z));
      const D3 spawned = x + lift * ng;
      // The plane through the visibility origin and the edge; m points away from the occluder.
      const auto awayFromOccluder = [&](const D3& o) {
        const D3 m = glm::normalize(glm::cross(a - o, b - o));
        return glm::dot(m, inside - o) > 0.0 ? -m : m;
      };
      const D3 m = awayFromOccluder(spawned);
      // The great-circle model holds if every ray of the cone meets the occluder's plane ahead, and there only
      // the edge (the +u side) can bound it: checked on the cone's rim and centre.
      for (int k = 0; k <= 16; ++k) {
        D3 w = s;
        if (k < 16) {
          const double phi = 2.0 * M_PI * k / 16.0;
          w = std::cos(alpha) * s + std::sin(alpha) * (std::cos(phi) * e1 + std::sin(phi) * e2);
        }
        const double denom = glm::dot(qn, w);
        ASSERT_GT(std::fabs(denom), 1e-3);
        const double t = glm::dot(qn, centre - x) / denom;
        ASSERT_GT(t, 0.0);
        const D3 p = x + t * w - centre;
        ASSERT_LT(std::fabs(glm::dot(p, c.occluderV) / glm::dot(c.occluderV, c.occluderV)), 0.9);
        ASSERT_GT(glm::dot(p, c.occluderU) / glm::dot(c.occluderU, c.occluderU), -0.9);
      }
      const double visible = VisibleCapCosineIntegral(s, alpha, n, m, 4000);
      const double whole = VisibleCapCosineIntegral(s, alpha, n, -m, 4000) + visible;
      share[i] = visible / whole;
      exact[i] = Y(albedo) / M_PI * double(radiance) * visible;
      unlifted[i] =
          Y(albedo) / M_PI * double(radiance) * VisibleCapCosineIntegral(s, alpha, n, awayFromOccluder(x), 4000);
      unoccluded = std::max(unoccluded, Y(albedo) / M_PI * double(radiance) * whole);
    }
    // Compared by z: the umbra (share 0: the reference must be exactly 0), the fully lit (share 1 exactly: the
    // great circle misses the cone) and the mid-penumbra (share in [0.1, 0.9]), where the occluded or the
    // visible part of the disc is no rare event for the pixel's samples. Elsewhere a sliver of the disc (under
    // 10%) is visible or hidden: its samples are rare events, the replicate means far from normal (a sliver no
    // replicate sampled leaves a tiny spread from the cosine alone), and z is no t statistic. Those pixels are held
    // to a deterministic bound instead: within 10% of the unoccluded value of the truth.
    const auto compared = [&](size_t i) {
      return share[i] == 0.0 || share[i] == 1.0 || (share[i] >= 0.1 && share[i] <= 0.9);
    };
    int umbra = 0, penumbra = 0, lit = 0, slivers = 0;
    double worstSliver = 0.0;
    for (size_t i = 0; i < r.g.Size(); ++i) {
      if (!r.g.IsSurface(i)) continue;
      if (!compared(i)) {
        ++slivers;
        const double error = std::fabs(Y(D3(r.ref.mean.pixels[i])) - exact[i]) / unoccluded;
        worstSliver = std::max(worstSliver, error);
        EXPECT_LE(error, 0.1) << "pixel " << i << ", visible share " << share[i];
      } else {
        share[i] == 0.0 ? ++umbra : share[i] == 1.0 ? ++lit : ++penumbra;
      }
    }
    const Verdict v = Compare(r, [&](size_t i) { return exact[i]; }, compared);
    // The same pixels against the visibility from the floor point itself, for the size of the spawn's effect.
    double sumRelative = 0.0;
    int count = 0;
    for (size_t i = 0; i < r.g.Size(); ++i)
      if (r.g.IsSurface(i) && compared(i) && unlifted[i] > 1e-3 * unoccluded) {
        sumRelative += Y(D3(r.ref.mean.pixels[i])) / unlifted[i] - 1.0;
        ++count;
      }
    std::printf("  d. %s: against visibility from the unlifted floor point the mean relative error is %+.4f%%\n",
                c.name.c_str(), 100.0 * sumRelative / std::max(1, count));
    std::printf("  d. %s: %d lit, %d mid-penumbra, %d umbra pixels compared; %d sliver pixels within %.2f%% of the "
                "unoccluded value (bound 10%%)\n",
                c.name.c_str(), lit, penumbra, umbra, slivers, 100.0 * worstSliver);
    ExpectAgreement(v, "d. " + c.name, 200, kEdgeMaxRelativeError);
    EXPECT_GE(penumbra, 200) << "the view must be mostly penumbra";
  }
}

// ---------------------------------------------------------------------------------------------------------
// e. GGX and layered planes under a constant environment.

// Gauss–Legendre nodes and weights on [-1, 1] (Newton on the Legendre polynomial; Numerical Recipes §4.6).
void GaussLegendre(int n, std::vector<double>& x, std::vector<double>& w) {
  x.assign(n, 0.0), w.assign(n, 0.0);
  for (int i = 0; i < n; ++i) {
    double z = std::cos(M_PI * (i + 0.75) / (n + 0.5)), dp = 0.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = 0.0;
      for (int j = 1; j <= n; ++j) {
        const double p2 = p1;
        p1 = p0;
        p0 = ((2.0 * j - 1.0) * z * p1 - (j - 1.0) * p2) / j;
      }
      dp = n * (z * p0 - p1) / (z * z - 1.0);
      const double dz = p0 / dp;
      z -= dz;
      if (std::fabs(dz) < 1e-15) break;
    }
    x[i] = z;
    w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
  }
}

// The GGX lobe's directional albedo per channel of F0, ∫ D G2 F / (4 cos θo cos θi) cos θi dωi, for the view at
// cos θo = cosO, written here from the formulas (Walter et al. 2007 Eq. 20, 33 for D; Heitz 2014 Eq. 99 for the
// height-correlated G2; Schlick's F with cos = ωo·h). In half vectors (dωi = 4 (ωo·h) dωh, dωh = sin θh dθh dφ):
//   ρ = 1/cos θo ∫dθh ∫dφ D(θh) sin θh G2 F (ωo·h)   over the h whose reflection ωi = 2 (ωo·h) h − ωo is above
// the horizon. With ωo = (sin θo, 0, cos θo), ωi.z = cos θo cos 2θh + sin θo sin 2θh cos φ: every φ qualifies
// while 2θh + θo < π/2, none once 2θh − θo > π/2, and in between the arc |φ| < φc, cos φc = −cos θo cos 2θh /
// (sin θo sin 2θh). So the θh range splits at those two angles, each part by Gauss–Legendre (`nodes` nodes), the
// full rings by the trapezoid rule in φ (periodic: spectrally accurate), the arcs by Gauss–Legendre on [0, φc]
// (the integrand is even in φ).
D3 GgxDirectionalAlbedo(double cosO, double alpha, const D3& f0, int nodes) {
  std::vector<double> gx, gw;
  GaussLegendre(nodes, gx, gw);
  const double sinO = std::sqrt(std::max(0.0, 1.0 - cosO * cosO)), thetaO = std::acos(cosO);
  const D3 wo(sinO, 0.0, cosO);
  const double a2 = alpha * alpha;
  const auto lambda = [&](double c) {
    const double tan2 = (1.0 - c * c) / (c * c);
    return 0.5 * (std::sqrt(1.0 + a2 * tan2) - 1.0);
  };
  // D G2 F (ωo·h) sin θh at (θh, φ); 0 where ωi is below the horizon.
  const auto integrand = [&](double th, double phi) {
    const double ch = std::cos(th), sh = std::sin(th);
    const D3 h(sh * std::cos(phi), sh * std::sin(phi), ch);
    const double oh = glm::dot(wo, h);
    const D3 wi = 2.0 * oh * h - wo;
    if (wi.z <= 0.0 || oh <= 0.0) return D3(0.0);
    const double denom = ch * ch * (a2 - 1.0) + 1.0;
    const double d = a2 / (M_PI * denom * denom);
    const double g2 = 1.0 / (1.0 + lambda(cosO) + lambda(wi.z));
    const double m5 = std::pow(1.0 - std::min(1.0, oh), 5.0);
    return (f0 + (D3(1.0) - f0) * m5) * (d * g2 * oh * sh);
  };
  const double full = 0.5 * (0.5 * M_PI - thetaO), none = std::min(0.5 * M_PI, 0.5 * (0.5 * M_PI + thetaO));
  const int ringNodes = 2 * nodes;
  D3 sum(0.0);
  for (int k = 0; k < nodes; ++k) {
    // Full rings, θh in [0, full].
    const double th = 0.5 * full * (gx[k] + 1.0);
    D3 ring(0.0);
    for (int j = 0; j < ringNodes; ++j) ring += integrand(th, 2.0 * M_PI * j / ringNodes);
    sum += ring * (2.0 * M_PI / ringNodes) * (0.5 * full * gw[k]);
    // Arcs, θh in [full, none].
    const double ta = full + 0.5 * (none - full) * (gx[k] + 1.0);
    const double c = -cosO * std::cos(2.0 * ta) / (sinO * std::sin(2.0 * ta));
    const double phiC = c <= -1.0 ? M_PI : c >= 1.0 ? 0.0 : std::acos(c);
    D3 arc(0.0);
    for (int j = 0; j < nodes; ++j) arc += integrand(ta, 0.5 * phiC * (gx[j] + 1.0)) * (0.5 * phiC * gw[j]);
    sum += 2.0 * arc * (0.5 * (none - full) * gw[k]);
  }
  return sum / cosO;
}

TEST(SkyClosedForm, GlossyPlanesUnderAConstantEnvironmentReflectTheirDirectionalAlbedo) {
  constexpr int kNodes = 96;
  const Vec3 colour(2.0f, 1.8f, 1.5f);
  struct GlossyCase {
    std::string name;
    Material material;
    Plane plane;
  };
  std::vector<GlossyCase> grid;
  {
    Material m;
    m.name = "ggx";
    m.type = MaterialType::kGgx;
    m.albedo = Vec3(0.9f, 0.6f, 0.3f);
    m.roughness = 0.5f;
    grid.push_back({"GGX roughness 0.5, tilted 25, 1000 m", m, {Far(1000.0), 25.0, 80.0}});
    m.roughness = 0.25f;
    grid.push_back({"GGX roughness 0.25, horizontal", m, {}});
  }
  {
    Material m;
    m.name = "layered";
    m.type = MaterialType::kLayered;
    m.albedo = Vec3(0.6f, 0.4f, 0.3f);
    m.roughness = 0.6f;
    m.metallic = 0.3f;
    m.specular = 0.5f;
    grid.push_back({"layered, tilted 50, 100 m", m, {Far(100.0), 50.0, 300.0}});
  }
  for (const GlossyCase& c : grid) {
    SCOPED_TRACE(c.name);
    Sequence seq = PlaneScene("glossy", c.plane, c.material, 1.0, 40.0, 32, 24);
    SetEnvironment(seq, 1, 1, {colour});
    const Rendered r = Render(seq, {1.0f, 0.0f});
    // sim/scene/shading_point.h MaterialBsdf's mapping, in double: alpha = roughness²; GGX: F0 = albedo; layered: the
    // specular share s = metallic + specular (1 − metallic), diffuse (1 − s) base, lobe F0 = (metallic base +
    // specular (1 − metallic)) / s.
    const Material& m = c.material;
    const double alpha = double(m.roughness) * double(m.roughness);
    const D3 base(m.albedo);
    const D3 n = c.plane.Normal();
    const D3 eye(r.state.camera.position);
    const auto truth = [&](size_t i) {
      const double cosO = glm::dot(n, glm::normalize(eye - D3(r.g.Position(i))));
      D3 rho;
      if (m.type == MaterialType::kGgx) {
        rho = GgxDirectionalAlbedo(cosO, alpha, base, kNodes);
      } else {
        const double s = double(m.metallic) + double(m.specular) * (1.0 - double(m.metallic));
        const D3 f0 = (double(m.metallic) * base + D3(double(m.specular) * (1.0 - double(m.metallic)))) / s;
        rho = (1.0 - s) * base + s * GgxDirectionalAlbedo(cosO, alpha, f0, kNodes);
      }
      return Y(rho * D3(colour));
    };
    // The quadrature converged (half the nodes agree to 1e-6), and with F0 = 1 (no Fresnel loss) the lobe
    // reflects at most 1 (single-scattering GGX loses energy, never gains).
    for (const double cosO : {0.98, 0.7, 0.4, 0.1}) {
      const D3 fine = GgxDirectionalAlbedo(cosO, alpha, base, kNodes);
      const D3 coarse = GgxDirectionalAlbedo(cosO, alpha, base, kNodes / 2);
      EXPECT_NEAR(coarse.x, fine.x, 1e-6 * fine.x) << "cos " << cosO;
      const double white = GgxDirectionalAlbedo(cosO, alpha, D3(1.0), kNodes).x;
      std::printf("  e. alpha %.4f, cos θo %.2f: GGX albedo with F0 = 1 %.6f (coarse rule off by %.1e)\n", alpha, cosO,
                  white, std::fabs(coarse.x / fine.x - 1.0));
      EXPECT_LE(white, 1.0) << "cos " << cosO;
    }
    ExpectAgreement(Compare(r, truth), "e. " + c.name, 300);
  }
}

// ---------------------------------------------------------------------------------------------------------
// f. The mixture: a quad light, a sun and a constant environment together.

TEST(SkyClosedForm, LocalLightSunAndEnvironmentTogether) {
  const D3 albedo(0.7, 0.65, 0.5);
  const float envRadiance = 0.3f;
  for (const bool far : {false, true}) {
    const std::string name = far ? "quad light + sun + environment, 1000 m" : "quad light + sun + environment";
    SCOPED_TRACE(name);
    const D3 origin = far ? Far(1000.0) : D3(0.0);
    Plane floor{origin, 0.0, 0.0, 50.0};
    Sequence seq = PlaneScene("mixture", floor, Diffuse(albedo), 1.6, 50.0, 32, 32);
    // A 0.4 m square light 0.8 m above the floor, facing down, tilted 20°.
    const double tilt = Radians(20.0);
    const D3 lc = origin + D3(0.1, 0.8, -0.1);
    const D3 u = 0.2 * D3(std::cos(tilt), std::sin(tilt), 0.0), v(0.0, 0.0, 0.2);
    // cross(u, v) points down (−y) for the tilt: the light faces the floor.
    test::AddQuadLight(seq, "light", Vec3(lc), Vec3(u), Vec3(v), Vec3(6.0f));
    SetEnvironment(seq, 1, 1, {Vec3(envRadiance)});
    const float sunDiameter = 2.0f;
    const double alpha = Radians(0.5 * double(sunDiameter));
    const float sunRadiance = static_cast<float>(1.5 / (M_PI * std::sin(alpha) * std::sin(alpha)));
    SetSun(seq, Vec3(sunRadiance), sunDiameter);
    // 20° up towards −x: the light's shadow falls 2.2 m beyond it along +x, outside the view (checked below).
    const D3 sunDir = glm::normalize(D3(-std::cos(Radians(20.0)), std::sin(Radians(20.0)), 0.0));
    SkyState sky{1.0f, 33.0f, Vec3(sunDir), 1.0f};
    const Rendered r = Render(seq, sky);
    const Light& light = seq.lights[0];
    const std::vector<Vec3> polygon{light.vertices[0], light.vertices[1], light.vertices[2], light.vertices[5]};
    const D3 front =
        glm::cross(D3(light.vertices[1]) - D3(light.vertices[0]), D3(light.vertices[2]) - D3(light.vertices[0]));
    const Vec3 n(0.0f, 1.0f, 0.0f);
    const double cosSun = glm::dot(glm::normalize(D3(Vec3(sunDir))), D3(n));
    const auto truth = [&](size_t i) {
      const Vec3 x = r.g.Position(i);
      // The light's solid angle, cosine-weighted (its front faces x: it lies above the floor's horizon).
      EXPECT_GT(glm::dot(front, D3(x) - D3(light.vertices[0])), 0.0);
      const double lightCosine = PolygonIrradiance(x, n, polygon, 1.0);
      // Rays towards the sun must pass the light: the sun's direction from x never meets its quad.
      const double e = 6.0 * lightCosine + double(sunRadiance) * M_PI * std::sin(alpha) * std::sin(alpha) * cosSun +
                       double(envRadiance) * (M_PI - lightCosine);
      return Y(albedo) / M_PI * e;
    };
    // The light never hides the sun from a floor point in view: the sun's centre ray crosses the light's plane
    // outside the quad (half-size 0.2 m) by more than the disc's spread there (t tan α), with a margin of 2.
    for (size_t i = 0; i < r.g.Size(); ++i) {
      if (!r.g.IsSurface(i)) continue;
      const D3 x(r.g.Position(i)), qn = glm::normalize(front);
      const double t = glm::dot(qn, lc - x) / glm::dot(qn, sunDir);
      if (t <= 0.0) continue;
      const D3 p = x + t * sunDir - lc;
      const double outside =
          std::max(std::fabs(glm::dot(p, glm::normalize(u))), std::fabs(glm::dot(p, glm::normalize(v)))) - 0.2;
      EXPECT_GT(outside, 2.0 * t * std::tan(alpha) / std::fabs(glm::dot(qn, sunDir))) << "pixel " << i;
    }
    ExpectAgreement(Compare(r, truth), "f. " + name);
  }
}

}  // namespace sky_closed_form_test
}  // namespace restir
