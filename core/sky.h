// The light at infinity (DESIGN §4, §8): an environment (an equirectangular radiance map, or a constant colour as
// a one-texel map) and a sun (a disc of uniform radiance). Samples of it are directions ω, with densities in
// solid angle; the estimators' target for one is L(ω) f_r max(0, n·ω) (DESIGN §4 "For an infinite light").
//
// Pure functions of their random numbers, as core/light_sampler.h. Directions are world space, +Y up.
#pragma once

#include <cstdint>
#include <vector>

#include "core/alias_table.h"
#include "core/light.h"
#include "core/math.h"

namespace restir {

// The light id a sample on the sky carries (LightSample::lightId; StoredReservoir::lightId). Never an index into a
// light list: a frame's lights are far fewer (sim/scene/sequence_reader.cpp caps them).
inline constexpr uint32_t kSkyLightId = 0x7fffffffu;
inline bool IsSkySample(uint32_t lightId) { return lightId == kSkyLightId; }

// Equirectangular radiance map in OpenEXR's latitude-longitude layout (ImfEnvmap.h, LatLongFromDirection): column 0
// at longitude +π, the last at -π, longitude = atan2(ω.x, ω.z); row 0 at latitude +π/2 (up, +Y), the last at -π/2,
// latitude = asin(ω.y). Texels are linear RGB radiance, row-major. A constant sky is the 1×1 map of its colour.
struct EnvironmentMap {
  int width = 0;
  int height = 0;
  std::vector<Vec3> texels;  // width * height, row 0 at the top
};

// The texel a unit map direction falls in (clamped to the map).
void EnvironmentTexelOf(const EnvironmentMap& map, const Vec3& mapDirection, int& column, int& row);
// Solid angle of a map row's texels: (2π / width) (sin λ_top - sin λ_bottom), λ the latitudes of its edges.
double EnvironmentTexelSolidAngle(const EnvironmentMap& map, int row);

// Importance sampling of an environment map: a texel with probability ∝ luminance × solid angle (an alias table
// over every texel; the "luminance × sin θ", integrated over the texel instead of taken at its centre, so
// that the density is exactly constant over each texel), then a direction uniform in solid angle within it (φ
// uniform in its column, sin λ uniform between its rows' edges). Density pdf(ω) = P(texel) / Ω(texel), in solid
// angle; radiance is the texel's value (nearest texel, no filtering), so the sampler is exactly proportional to
// luminance. Built once per map.
class EnvironmentSampler {
 public:
  EnvironmentSampler() = default;
  explicit EnvironmentSampler(const EnvironmentMap& map);

  // No texel has positive luminance: nothing to sample (pdf 0 everywhere).
  bool Empty() const { return table_.Empty(); }
  // A map direction from four uniforms: two choose the texel (alias table), two the direction in it. pdf: its
  // solid-angle density (0 when Empty()).
  Vec3 Sample(float uSelect, float uCoin, float uPhi, float uLatitude, float& pdf) const;
  // Solid-angle density of Sample producing the map direction ω.
  float Pdf(const Vec3& mapDirection) const;
  // The map's radiance towards the map direction ω.
  Vec3 Radiance(const Vec3& mapDirection) const;
  const EnvironmentMap& Map() const { return map_; }

 private:
  EnvironmentMap map_;
  AliasTable table_;
  std::vector<float> rowSolidAngle_;  // Ω of a texel of each row
};

// A disc of uniform radiance seen from everywhere under the same direction (the sun), sampled uniformly in its
// cone: cos θ uniform in [cos α, 1], pdf = 1 / (2π (1 - cos α)) (pbrt-v4 SampleUniformCone).
struct SunDisc {
  Vec3 direction{0.0f, 1.0f, 0.0f};  // unit, towards the sun's centre
  Vec3 radiance{0.0f};                // inside the disc
  // 1 - cos α for the half-angle α, as 2 sin²(α/2): exact for the tiny cones of a real sun (α = 0.265°, where
  // 1 - cos α = 1.07e-5 would keep three significant digits if computed in float from cos α).
  float oneMinusCos = 0.0f;
  // |ω - direction|² below which ω is in the disc: the chord 2 sin(α/2), squared. The same test for every
  // direction (sampled or not), computed without cancellation.
  float chord2 = 0.0f;
};

// A sun of the given angular diameter (degrees, > 0 and < 180) and radiance.
SunDisc MakeSunDisc(const Vec3& direction, float angularDiameterDegrees, const Vec3& radiance);
// The radiance of a sun whose illuminance at normal incidence is `illuminance`: E = π L sin²α (a disc of half-angle
// α and uniform radiance L).
Vec3 SunRadianceFromIlluminance(const Vec3& illuminance, float angularDiameterDegrees);
inline bool InSunDisc(const SunDisc& s, const Vec3& w) {
  const Vec3 d = w - s.direction;
  return glm::dot(d, d) < s.chord2;
}
// A direction uniform in the disc's cone from two uniforms.
Vec3 SampleSunDisc(const SunDisc& s, float u0, float u1);
inline float SunDiscPdf(const SunDisc& s, const Vec3& w) {
  return InSunDisc(s, w) && s.oneMinusCos > 0.0f ? 1.0f / (2.0f * kPi * s.oneMinusCos) : 0.0f;
}

// The sky of one frame: the environment (scaled and rotated about +Y) plus the sun. The environment sampler is
// shared by every frame (built once per sequence) and must outlive this.
struct Sky {
  const EnvironmentSampler* environment = nullptr;  // null: no environment this frame
  Vec3 environmentScale{1.0f};                      // multiplies the map's radiance (intensity key)
  float cosRotation = 1.0f;                         // rotation of the map about +Y: world = R(ρ) map
  float sinRotation = 0.0f;
  bool hasSun = false;
  SunDisc sun;

  bool HasEnvironment() const { return environment != nullptr && !environment->Empty(); }
  bool Empty() const { return !HasEnvironment() && !hasSun; }
  Vec3 ToMap(const Vec3& world) const;
  Vec3 ToWorld(const Vec3& map) const;
  // Total radiance towards ω: environment plus sun (L_e(ω) of DESIGN §4 for a sky sample).
  Vec3 Radiance(const Vec3& w) const;
  // Its two parts: the environment's (0 without one), and the sun's (its radiance inside the disc, else 0).
  Vec3 EnvironmentRadiance(const Vec3& w) const;
  Vec3 SunRadiance(const Vec3& w) const { return hasSun && InSunDisc(sun, w) ? sun.radiance : Vec3(0.0f); }
  // The environment strategy: a world direction and its solid-angle density.
  Vec3 SampleEnvironment(float uSelect, float uCoin, float uPhi, float uLatitude, float& pdf) const;
  float EnvironmentPdf(const Vec3& w) const;
  // The sun strategy.
  Vec3 SampleSun(float u0, float u1, float& pdf) const;
  float SunPdf(const Vec3& w) const { return hasSun ? SunDiscPdf(sun, w) : 0.0f; }
};

// A direction sample as a light point that the shading equations of core/shading.h evaluate exactly as the
// direction: the point x + R ω with R = kSkyDistance, facing back along -ω, with radiance L R². Then
// ConnectToLight gives ω (to float rounding of R ω, ~6e-8), G = cos θx cos θy / R² with cos θy = 1 to rounding,
// and L_e f_r G = L f_r cos θx: the solid-angle integrand. R is a power of two, so the factor R² is exact; and it
// dwarfs any scene (coordinates are at most 1e7, sim/scene/sequence.h), so the shadow ray to the point leaves the
// scene. Every pass turns a stored direction into the point of its own receiver, so the shift between pixels is the
// identity on ω with Jacobian 1 (DESIGN §4).
inline constexpr float kSkyDistance = 0x1p30f;
inline LightSample SkyPointFor(const Vec3& receiver, const Vec3& w, const Vec3& radiance) {
  LightSample y;
  y.lightId = kSkyLightId;
  y.position = receiver + kSkyDistance * w;
  y.normal = -w;
  y.radiance = radiance * (kSkyDistance * kSkyDistance);
  y.pdfArea = 0.0f;
  return y;
}

}  // namespace restir
