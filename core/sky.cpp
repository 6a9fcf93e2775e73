#include "core/sky.h"

#include <algorithm>
#include <cmath>

namespace restir {

namespace {

// Latitude of the top edge of `row` of a map `height` rows high: +π/2 at row 0, -π/2 at row `height`.
double RowEdgeLatitude(int row, int height) { return 0.5 * M_PI - M_PI * double(row) / double(height); }

}  // namespace

void EnvironmentTexelOf(const EnvironmentMap& map, const Vec3& w, int& column, int& row) {
  // OpenEXR LatLongFromDirection: longitude atan2(x, z) from +π (column 0) to -π; latitude asin(y) from +π/2.
  const float longitude = std::atan2(w.x, w.z);
  const float latitude = std::asin(std::clamp(w.y, -1.0f, 1.0f));
  const float u = (kPi - longitude) / (2.0f * kPi);
  const float v = (0.5f * kPi - latitude) / kPi;
  column = std::clamp(static_cast<int>(u * static_cast<float>(map.width)), 0, map.width - 1);
  row = std::clamp(static_cast<int>(v * static_cast<float>(map.height)), 0, map.height - 1);
}

double EnvironmentTexelSolidAngle(const EnvironmentMap& map, int row) {
  const double top = RowEdgeLatitude(row, map.height), bottom = RowEdgeLatitude(row + 1, map.height);
  return (2.0 * M_PI / double(map.width)) * (std::sin(top) - std::sin(bottom));
}

EnvironmentSampler::EnvironmentSampler(const EnvironmentMap& map) : map_(map) {
  rowSolidAngle_.resize(static_cast<size_t>(map.height));
  for (int r = 0; r < map.height; ++r) rowSolidAngle_[r] = static_cast<float>(EnvironmentTexelSolidAngle(map, r));
  std::vector<float> weights(map.texels.size(), 0.0f);
  for (int r = 0; r < map.height; ++r)
    for (int c = 0; c < map.width; ++c) {
      const size_t i = static_cast<size_t>(r) * map.width + c;
      const float y = Luminance(map.texels[i]);
      // A texel whose luminance is not positive and finite is never chosen; its radiance is still returned.
      weights[i] = (y > 0.0f && std::isfinite(y)) ? y * rowSolidAngle_[r] : 0.0f;
    }
  table_ = AliasTable(weights);
}

Vec3 EnvironmentSampler::Sample(float uSelect, float uCoin, float uPhi, float uLatitude, float& pdf) const {
  pdf = 0.0f;
  if (Empty()) return Vec3(0.0f, 1.0f, 0.0f);
  const uint32_t i = table_.Sample(uSelect, uCoin);
  const int row = static_cast<int>(i / static_cast<uint32_t>(map_.width));
  const int column = static_cast<int>(i % static_cast<uint32_t>(map_.width));
  // Uniform in solid angle within the texel: longitude uniform across the column, sin(latitude) uniform between
  // the row's edges (dω = dlongitude d sin(latitude)).
  const float longitude =
      kPi - 2.0f * kPi * (static_cast<float>(column) + uPhi) / static_cast<float>(map_.width);
  const float sinTop = static_cast<float>(std::sin(RowEdgeLatitude(row, map_.height)));
  const float sinBottom = static_cast<float>(std::sin(RowEdgeLatitude(row + 1, map_.height)));
  auto direction = [&](float longitude, float uLat) {
    const float y = std::clamp(sinTop + (sinBottom - sinTop) * uLat, -1.0f, 1.0f);
    const float r = std::sqrt(std::max(0.0f, 1.0f - y * y));
    return Vec3(r * std::sin(longitude), y, r * std::cos(longitude));
  };
  Vec3 w = direction(longitude, uLatitude);
  // Rounding can put a draw within an ulp of the texel's edge into its neighbour (a 2^-24 chance per draw), whose
  // density may be 0: such a draw takes the texel's centre instead, so every sample lies in the texel it chose.
  // The mass moved is at most 2^-24 of the texel's.
  int c, rr;
  EnvironmentTexelOf(map_, w, c, rr);
  if (c != column || rr != row)
    w = direction(kPi - 2.0f * kPi * (static_cast<float>(column) + 0.5f) / static_cast<float>(map_.width), 0.5f);
  // The density of the texel the direction lands in: float rounding can move a direction sampled at a texel's
  // edge into its neighbour, and Pdf() must agree with Sample() for every direction it returns.
  pdf = Pdf(w);
  return w;
}

float EnvironmentSampler::Pdf(const Vec3& w) const {
  if (Empty()) return 0.0f;
  int column, row;
  EnvironmentTexelOf(map_, w, column, row);
  const float omega = rowSolidAngle_[static_cast<size_t>(row)];
  return omega > 0.0f ? table_.Pmf(static_cast<uint32_t>(row * map_.width + column)) / omega : 0.0f;
}

Vec3 EnvironmentSampler::Radiance(const Vec3& w) const {
  if (map_.texels.empty()) return Vec3(0.0f);
  int column, row;
  EnvironmentTexelOf(map_, w, column, row);
  return map_.texels[static_cast<size_t>(row) * map_.width + column];
}

SunDisc MakeSunDisc(const Vec3& direction, float angularDiameterDegrees, const Vec3& radiance) {
  SunDisc s;
  s.direction = glm::normalize(direction);
  s.radiance = radiance;
  const double halfAngle = 0.5 * double(angularDiameterDegrees) * M_PI / 180.0;
  const double sinHalfHalf = std::sin(0.5 * halfAngle);
  s.oneMinusCos = static_cast<float>(2.0 * sinHalfHalf * sinHalfHalf);
  s.chord2 = static_cast<float>(4.0 * sinHalfHalf * sinHalfHalf);
  return s;
}

Vec3 SunRadianceFromIlluminance(const Vec3& illuminance, float angularDiameterDegrees) {
  const double sinHalf = std::sin(0.5 * double(angularDiameterDegrees) * M_PI / 180.0);
  return illuminance * static_cast<float>(1.0 / (M_PI * sinHalf * sinHalf));
}

Vec3 SampleSunDisc(const SunDisc& s, float u0, float u1) {
  // 1 - cos θ = u0 (1 - cos α); sin θ from it without cancellation: sin² = (1 - cos)(1 + cos).
  const float oneMinusCos = u0 * s.oneMinusCos;
  const float cosTheta = 1.0f - oneMinusCos;
  const float sinTheta = std::sqrt(std::max(0.0f, oneMinusCos * (2.0f - oneMinusCos)));
  const float phi = 2.0f * kPi * u1;
  Vec3 t, b;
  OrthonormalBasis(s.direction, t, b);
  Vec3 w = glm::normalize(sinTheta * std::cos(phi) * t + sinTheta * std::sin(phi) * b + cosTheta * s.direction);
  // Float rounding of w (~1e-7) can put a draw at the rim outside InSunDisc, where the sun has no radiance and
  // SunDiscPdf is 0 (for the 0.1° sun about 1e-5 of draws): such a draw is pulled towards the centre by 0.1% of
  // its offset until it is inside. The distribution moves by 1e-3 of the radius on a set of probability ~1e-5.
  for (float pull = 0.999f; !InSunDisc(s, w) && pull > 0.5f; pull -= 0.05f)
    w = glm::normalize(s.direction + pull * (w - s.direction));
  return w;
}

Vec3 Sky::ToMap(const Vec3& w) const {
  // The inverse rotation about +Y.
  return Vec3(cosRotation * w.x - sinRotation * w.z, w.y, sinRotation * w.x + cosRotation * w.z);
}

Vec3 Sky::ToWorld(const Vec3& m) const {
  return Vec3(cosRotation * m.x + sinRotation * m.z, m.y, -sinRotation * m.x + cosRotation * m.z);
}

Vec3 Sky::EnvironmentRadiance(const Vec3& w) const {
  return environment != nullptr ? environmentScale * environment->Radiance(ToMap(w)) : Vec3(0.0f);
}

Vec3 Sky::Radiance(const Vec3& w) const {
  Vec3 l = EnvironmentRadiance(w);
  if (hasSun && InSunDisc(sun, w)) l += sun.radiance;
  return l;
}

Vec3 Sky::SampleEnvironment(float uSelect, float uCoin, float uPhi, float uLatitude, float& pdf) const {
  pdf = 0.0f;
  if (!HasEnvironment()) return Vec3(0.0f, 1.0f, 0.0f);
  const Vec3 w = ToWorld(environment->Sample(uSelect, uCoin, uPhi, uLatitude, pdf));
  // Rotating back and forth can move a direction on a texel edge across it: the density is that of where the
  // direction is looked up.
  pdf = EnvironmentPdf(w);
  return w;
}

float Sky::EnvironmentPdf(const Vec3& w) const { return HasEnvironment() ? environment->Pdf(ToMap(w)) : 0.0f; }

Vec3 Sky::SampleSun(float u0, float u1, float& pdf) const {
  pdf = 0.0f;
  if (!hasSun) return sun.direction;
  const Vec3 w = SampleSunDisc(sun, u0, u1);
  pdf = SunPdf(w);
  return w;
}

}  // namespace restir
