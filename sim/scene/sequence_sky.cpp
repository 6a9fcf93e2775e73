// The sky of a sequence file (docs/sequence-format.md "Sky"; DESIGN §8): the `environment` (an equirectangular
// map file or a constant colour) and the `sun`, each with keyframes and `on` ranges like the scene's other
// animated things, read with the same located errors (DESIGN §10) as the rest of the file
// (sim/scene/sequence_reader.cpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "sim/scene/animation.h"
#include "sim/util/hash.h"
#include "sim/util/input_file.h"
#include "sim/scene/sequence_reader.h"
#include "sim/scene/sky_frame.h"
#include "sim/assets/texture_decode.h"

namespace restir {
namespace sequence_internal {

namespace {

// As for textures (docs/sequence-format.md "Scene limits"): the decoder's own bounds on texels apply after this.
constexpr size_t kMaxEnvironmentBytes = size_t(256) << 20;
// Below this the disc's density 1 / (2π (1 - cos α)) passes 4e11 per steradian, and a sample's weight the headroom
// the radiance bound leaves in single precision; the real sun is 0.53°.
constexpr float kMinSunDiameterDegrees = 1e-4f;
constexpr float kMaxSunDiameterDegrees = 30.0f;

float MaxComponent(const Vec3& v) { return std::max({v.x, v.y, v.z}); }

}  // namespace

// An intensity of the sky may be 0 (a key fading it out); like a light's, it may pass the bound on other numbers,
// since it only scales a radiance that has its own bound (kMaxRadiance).
float Reader::SkyIntensity(const Json& v, const std::string& p) const {
  const float f = Float(v, p, kMaxRadiance, "an intensity");
  if (!(f >= 0.0f)) Fail(p, "intensity must be >= 0, got " + FormatNumber(f));
  return f;
}

void Reader::ReadEnvironment(const Json& e, const std::string& p, Sequence& seq) {
  CheckKeys(e, p, {"file", "color", "intensity", "rotation", "keyframes", "on"});
  Environment env;
  const Json* file = Find(e, "file");
  const Json* color = Find(e, "color");
  if (file && color) Fail(p + "/color", "give either 'file' or 'color', not both");
  if (!file && !color) Fail(p, "missing required key 'file' or 'color' (a map file or a constant sky)");
  if (file) {
    env.file = String(*file, p + "/file");
    env.map = LoadEnvironmentMap(env.file, p + "/file");
  } else {
    env.map.width = env.map.height = 1;
    env.map.texels = {Color(*color, p + "/color", "color", false)};
  }

  // keyPaths[i]: the pointer of keys[i], to name its intensity when the product with the map is too bright (only
  // a given intensity can be: the default 1 times a texel is within the bound).
  std::vector<std::string> keyPaths;
  if (const Json* list = Find(e, "keyframes")) {
    for (const char* k : {"intensity", "rotation"})
      if (Find(e, k))
        Fail(p + "/" + k, std::string("with 'keyframes' give the ") + k + " in each key, not here");
    const std::string lp = p + "/keyframes";
    AsArray(*list, lp, true);
    for (size_t i = 0; i < list->size(); ++i) {
      const std::string kp = PointerChild(lp, i);
      const Json& k = AsObject((*list)[i], kp);
      CheckKeys(k, kp, {"frame", "intensity", "rotation", "interpolation"});
      EnvironmentKey key;
      key.frame = ReadKeyFrame(k, kp);
      if (const Json* v = Find(k, "intensity")) key.intensity = SkyIntensity(*v, kp + "/intensity");
      if (const Json* v = Find(k, "rotation")) key.rotationDegrees = Float(*v, kp + "/rotation");
      key.interpolation = ReadInterpolation(k, kp);
      env.keys.push_back(key);
      keyPaths.push_back(kp);
    }
    SortKeys(env.keys, keyPaths);
  } else {
    EnvironmentKey key;
    if (const Json* v = Find(e, "intensity")) key.intensity = SkyIntensity(*v, p + "/intensity");
    if (const Json* v = Find(e, "rotation")) key.rotationDegrees = Float(*v, p + "/rotation");
    env.keys.push_back(key);
    keyPaths.push_back(p);
  }
  // Every texel is within kMaxRadiance and every intensity too, but not their product.
  float brightest = 0.0f;
  for (const Vec3& t : env.map.texels) brightest = std::max(brightest, MaxComponent(t));
  for (size_t i = 0; i < env.keys.size(); ++i) {
    const double radiance = double(brightest) * env.keys[i].intensity;
    if (radiance > kMaxRadiance)
      Fail(keyPaths[i] + "/intensity",
           "the environment's radiance reaches " + FormatNumber(radiance) + " (brightest texel " +
               FormatNumber(brightest) + " x intensity " + FormatNumber(env.keys[i].intensity) +
               "), beyond the limit of 1e12 (products with it must stay finite in single precision)");
  }
  if (const Json* v = Find(e, "on")) env.onRanges = ReadOnRanges(*v, p + "/on", "an environment");
  env.present = true;
  PrepareEnvironment(env);
  seq.environment = std::move(env);
}

// The map file, resolved against the sequence's directory like an asset, read once and decoded by OpenImageIO
// (sim/assets/texture_decode.h). Its texels enter the content hash, so an edit to the map changes the reference
// cache key.
EnvironmentMap Reader::LoadEnvironmentMap(const std::string& file, const std::string& p) {
  namespace fs = std::filesystem;
  if (file.empty()) Fail(p, "file name must not be empty");
  fs::path resolved = fs::path(file);
  if (resolved.is_relative()) resolved = fs::path(baseDir_.empty() ? "." : baseDir_) / resolved;
  const std::string path = resolved.lexically_normal().string();
  std::string bytes, problem;
  if (!TryReadRegularFile(path, kMaxEnvironmentBytes, bytes, problem))
    Fail(p, "cannot read file '" + path + "' (" + problem + ")");
  Texture image;
  if (!TryDecodeLinearImage(bytes, path, image, problem))
    Fail(p, "cannot decode environment map '" + path + "': " + problem);
  std::string().swap(bytes);
  EnvironmentMap map;
  map.width = image.width;
  map.height = image.height;
  map.texels.resize(static_cast<size_t>(map.width) * static_cast<size_t>(map.height));
  bool lit = false;
  for (size_t i = 0; i < map.texels.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const float v = image.rgb[3 * i + static_cast<size_t>(c)];
      // Radiance is never negative and must be finite; the sampler would skip such a texel but the estimators
      // would still read it. Named by column and row as an image viewer shows them (row 0 at the top).
      if (!std::isfinite(v) || v < 0.0f || v > kMaxRadiance) {
        const size_t column = i % static_cast<size_t>(map.width), row = i / static_cast<size_t>(map.width);
        Fail(p, "environment map '" + path + "' has " +
                    (!std::isfinite(v) ? std::string("a non-finite value")
                     : v < 0.0f       ? "a negative value " + FormatNumber(v)
                                      : "the value " + FormatNumber(v)) +
                    " in channel " + std::string(1, "RGB"[c]) + " of the texel at column " + std::to_string(column) +
                    ", row " + std::to_string(row) + " (radiance must be finite, >= 0 and at most 1e12)");
      }
      lit = lit || v > 0.0f;
    }
    map.texels[i] = Vec3(image.rgb[3 * i], image.rgb[3 * i + 1], image.rgb[3 * i + 2]);
  }
  if (!lit) Fail(p, "environment map '" + path + "' is black everywhere (it would emit nothing)");
  const int32_t size[2] = {map.width, map.height};
  hash_ = Fnv1a(size, sizeof(size), hash_);
  hash_ = Fnv1a(map.texels.data(), map.texels.size() * sizeof(Vec3), hash_);
  return map;
}

// A direction towards the sun: any non-zero length, normalised in double so that tiny components still give one.
Vec3 Reader::SunDirection(const Json& v, const std::string& p) const {
  const glm::dvec3 d(Vector(v, p));
  const double length = glm::length(d);
  if (!(length > 0.0)) Fail(p, "the sun's direction must not be zero");
  return Vec3(d / length);
}

void Reader::ReadSun(const Json& s, const std::string& p, Sequence& seq) {
  CheckKeys(s, p, {"direction", "angularDiameter", "radiance", "illuminance", "intensity", "keyframes", "on"});
  Sun sun;
  if (const Json* v = Find(s, "angularDiameter")) {
    sun.angularDiameterDegrees = Float(*v, p + "/angularDiameter");
    if (!(sun.angularDiameterDegrees >= kMinSunDiameterDegrees &&
          sun.angularDiameterDegrees <= kMaxSunDiameterDegrees))
      Fail(p + "/angularDiameter", "angularDiameter must be in (0, 30] degrees (and at least 1e-4), got " +
                                       FormatNumber(sun.angularDiameterDegrees));
  }
  const Json* radiance = Find(s, "radiance");
  const Json* illuminance = Find(s, "illuminance");
  if (radiance && illuminance) Fail(p + "/illuminance", "give either 'radiance' or 'illuminance', not both");
  if (!radiance && !illuminance) Fail(p, "missing required key 'radiance' or 'illuminance'");
  std::string radiancePath;
  if (radiance) {
    // The real sun's radiance (~1.6e9 W/m²/sr) is past the bound on other numbers; it has its own (kMaxRadiance).
    radiancePath = p + "/radiance";
    if (!radiance->is_array() || radiance->size() != 3)
      Fail(radiancePath, "expected an array of 3 numbers, got " +
                             (radiance->is_array() ? "an array of " + std::to_string(radiance->size())
                                                   : JsonTypeName(*radiance)));
    for (int c = 0; c < 3; ++c)
      sun.radiance[c] =
          Float((*radiance)[size_t(c)], PointerChild(radiancePath, size_t(c)), kMaxRadiance, "a radiance");
    if (std::min({sun.radiance.x, sun.radiance.y, sun.radiance.z}) < 0.0f)
      Fail(radiancePath, "radiance components must be >= 0, got " + FormatVec(sun.radiance));
  } else {
    radiancePath = p + "/illuminance";
    const Vec3 e = Color(*illuminance, radiancePath, "illuminance", true);
    sun.radiance = SunRadianceFromIlluminance(e, sun.angularDiameterDegrees);  // E = π L sin²α
    if (!(MaxComponent(sun.radiance) <= kMaxRadiance))
      Fail(radiancePath, "the sun's radiance E / (pi sin^2 a) is " + FormatVec(sun.radiance) +
                             " for this illuminance and angularDiameter, beyond the limit of 1e12");
  }
  if (!(MaxComponent(sun.radiance) > 0.0f)) Fail(radiancePath, "the sun must not be black");

  std::vector<std::string> keyPaths;  // as for the environment
  if (const Json* list = Find(s, "keyframes")) {
    for (const char* k : {"direction", "intensity"})
      if (Find(s, k)) Fail(p + "/" + k, std::string("with 'keyframes' give the ") + k + " in each key, not here");
    const std::string lp = p + "/keyframes";
    AsArray(*list, lp, true);
    for (size_t i = 0; i < list->size(); ++i) {
      const std::string kp = PointerChild(lp, i);
      const Json& k = AsObject((*list)[i], kp);
      CheckKeys(k, kp, {"frame", "direction", "intensity", "interpolation"});
      SunKey key;
      key.frame = ReadKeyFrame(k, kp);
      key.direction = SunDirection(Need(k, kp, "direction"), kp + "/direction");
      if (const Json* v = Find(k, "intensity")) key.intensity = SkyIntensity(*v, kp + "/intensity");
      key.interpolation = ReadInterpolation(k, kp);
      sun.keys.push_back(key);
      keyPaths.push_back(kp);
    }
    SortKeys(sun.keys, keyPaths);
  } else {
    SunKey key;
    key.direction = SunDirection(Need(s, p, "direction"), p + "/direction");
    if (const Json* v = Find(s, "intensity")) key.intensity = SkyIntensity(*v, p + "/intensity");
    sun.keys.push_back(key);
    keyPaths.push_back(p);
  }
  for (size_t i = 0; i < sun.keys.size(); ++i) {
    const double r = double(MaxComponent(sun.radiance)) * sun.keys[i].intensity;
    if (r > kMaxRadiance)
      Fail(keyPaths[i] + "/intensity", "the sun's radiance reaches " + FormatNumber(r) + " (radiance x intensity " +
                                           FormatNumber(sun.keys[i].intensity) + "), beyond the limit of 1e12");
  }
  if (const Json* v = Find(s, "on")) sun.onRanges = ReadOnRanges(*v, p + "/on", "a sun");
  sun.present = true;
  seq.sun = std::move(sun);
}

namespace {

// "intensity 0.5..2" over the keys, or "intensity 1" when they agree.
template <typename Key, typename Get>
std::string Range(const std::vector<Key>& keys, const char* what, Get get, const char* unit) {
  float lo = get(keys.front()), hi = lo;
  for (const Key& k : keys) lo = std::min(lo, get(k)), hi = std::max(hi, get(k));
  char buf[128];
  if (lo == hi) std::snprintf(buf, sizeof(buf), "%s %g%s", what, lo, unit);
  else std::snprintf(buf, sizeof(buf), "%s %g..%g%s", what, lo, hi, unit);
  return buf;
}

std::string Switching(const std::vector<std::pair<int, int>>& onRanges) {
  if (onRanges.empty()) return "always on";
  std::string s = "on";
  for (const auto& [first, last] : onRanges) s += " [" + std::to_string(first) + ", " + std::to_string(last) + ")";
  return s;
}

}  // namespace

std::string SummarizeSky(const Sequence& seq) {
  std::ostringstream out;
  const Environment& e = seq.environment;
  if (e.present && !e.keys.empty()) {
    out << "environment ";
    if (!e.file.empty()) {
      out << e.file << ", " << e.map.width << "x" << e.map.height << " texels";
    } else if (!e.map.texels.empty()) {
      out << "colour " << FormatVec(e.map.texels[0]);
    }
    out << "; " << e.keys.size() << (e.keys.size() == 1 ? " key: " : " keys: ")
        << Range(e.keys, "intensity", [](const EnvironmentKey& k) { return k.intensity; }, "") << ", "
        << Range(e.keys, "rotation", [](const EnvironmentKey& k) { return k.rotationDegrees; }, " deg") << "; "
        << Switching(e.onRanges) << "\n";
  }
  const Sun& s = seq.sun;
  if (s.present && !s.keys.empty()) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%g", s.angularDiameterDegrees);
    out << "sun         radiance " << FormatVec(s.radiance) << ", diameter " << buf << " deg; " << s.keys.size()
        << (s.keys.size() == 1 ? " key: " : " keys: ") << "direction " << FormatVec(s.keys.front().direction);
    if (s.keys.size() > 1) out << " .. " << FormatVec(s.keys.back().direction);
    out << ", " << Range(s.keys, "intensity", [](const SunKey& k) { return k.intensity; }, "") << "; "
        << Switching(s.onRanges) << "\n";
  }
  return out.str();
}

}  // namespace sequence_internal
}  // namespace restir
