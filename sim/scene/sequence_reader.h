// The sequence reader (sim/scene/sequence.h ParseSequence) as a class shared by the files that implement it:
// sim/scene/sequence_reader.cpp reads the scene, the lights, the camera and the render defaults,
// sim/scene/sequence_sky.cpp the environment and the sun. Nothing else includes this: the rest of the program
// calls ParseSequence / LoadSequence.
#pragma once

#include <algorithm>
#include <cstdio>
#include <map>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "sim/assets/asset_import.h"
#include "sim/util/hash.h"
#include "sim/util/json_reader.h"
#include "sim/scene/sequence.h"
#include "sim/util/text.h"

namespace restir {
namespace sequence_internal {

inline std::string FormatNumber(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

inline std::string FormatVec(const Vec3& v) {
  char buf[128];
  std::snprintf(buf, sizeof(buf), "[%g, %g, %g]", v.x, v.y, v.z);
  return buf;
}

// Whole-scene budgets. Every shape and grid has its own bound, but a few kilobytes of JSON repeating the
// largest ones (1024-segment spheres, 10000 window bars, 65536-light grids) would otherwise take gigabytes and
// many seconds to generate before anything could complain; the fuzzer's hang and memory limits hold the
// parser to that. Far above any shipped sequence (docs/sequence-format.md, "Limits").
constexpr size_t kMaxSceneTriangles = size_t(1) << 22;  // 4,194,304 object triangles
constexpr size_t kMaxLights = size_t(1) << 18;          // 262,144 lights (524,288 emitter triangles for quads)
constexpr size_t kMaxEmitterTriangles = size_t(1) << 20;  // 1,048,576 emissive triangles of imported assets

// Finite float arithmetic (issue 14): every world-space point of an object under any of its keyframes is at most
// kMaxWorldExtent from the origin and every light's radiance (colour x intensity) at most kMaxRadiance, besides
// kMaxSequenceNumber (sequence.h) on every number. Then squared distances (<= 1e17), triangle areas and Embree's
// ray-triangle products (<= 1e25), light powers (<= 1e30) and the integrand L f G (L <= 1e12, G <= 1e12 above
// the 1e-6 m guard) all stay far below FLT_MAX = 3.4e38, so `validate` and `run` agree and Embree never sees an
// invalid ray. Far beyond any scene: 100,000 km.
constexpr double kMaxWorldExtent = 1e8;
constexpr double kMaxRadiance = 1e12;
// A sequence file is text of a few kilobytes; the cap keeps a hostile one (/dev/zero, a million keyframes) from
// taking the machine's memory before it can be refused.
constexpr size_t kMaxSequenceBytes = size_t(16) << 20;
constexpr size_t kMaxMeshBytes = size_t(1) << 30;

// --- the reader
// ---------------------------------------------------------------------------------------------

class Reader : public JsonReader {
 public:
  Reader(const std::string& file, std::string text, const std::string& baseDir)
      : JsonReader(file, std::move(text)), baseDir_(baseDir), hash_(Fnv1a(Text().data(), Text().size())) {
    SetMagnitudeLimit(kMaxSequenceNumber, "a sequence's numbers");
  }

  Sequence Read(const Json& root);
  std::string Hash() const { return HexHash(hash_); }

 private:
  Vec3 Color(const Json& v, const std::string& p, const std::string& what, bool allowBlack) const {
    const Vec3 c = Vector(v, p);
    if (c.x < 0.0f || c.y < 0.0f || c.z < 0.0f)
      Fail(p, what + " components must be >= 0, got " + FormatVec(c));
    if (!allowBlack && std::max({c.x, c.y, c.z}) <= 0.0f) Fail(p, what + " must not be black");
    return c;
  }
  float Positive(const Json& v, const std::string& p, const std::string& what) const {
    const float f = Float(v, p);
    if (!(f > 0.0f)) Fail(p, what + " must be > 0, got " + FormatNumber(f));
    return f;
  }
  // A light's intensity scales only its colour, and their product has its own bound (kMaxRadiance), so a sun's
  // radiance can be given as an intensity past the bound on other numbers.
  float Intensity(const Json& v, const std::string& p) const {
    const float f = Float(v, p, kMaxRadiance, "an intensity");
    if (!(f > 0.0f)) Fail(p, "intensity must be > 0, got " + FormatNumber(f));
    return f;
  }
  // One of a closed set of strings; suggests the nearest on a typo.
  size_t Choice(const Json& v, const std::string& p, const std::string& what,
                const std::vector<std::string>& options) const {
    const std::string s = String(v, p);
    auto it = std::find(options.begin(), options.end(), s);
    if (it == options.end()) Fail(p, "unknown " + what + " '" + s + "'" + Suggestion(s, options));
    return static_cast<size_t>(it - options.begin());
  }
  Interpolation ReadInterpolation(const Json& key, const std::string& p) const {
    const Json* v = Find(key, "interpolation");
    if (!v) return Interpolation::kLinear;
    return Choice(*v, PointerChild(p, "interpolation"), "interpolation", {"linear", "smooth"}) == 0
               ? Interpolation::kLinear
               : Interpolation::kSmooth;
  }
  int ReadKeyFrame(const Json& key, const std::string& p) const {
    return static_cast<int>(
        Integer(Need(key, p, "frame"), PointerChild(p, "frame"), 0, frameCount_ - 1, "frame"));
  }

  // Sorts keys by frame and rejects two keys on one frame. paths[i] is the pointer of keys[i] as written.
  template <typename Key>
  void SortKeys(std::vector<Key>& keys, std::vector<std::string>& paths) const {
    std::vector<size_t> order(keys.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return keys[a].frame < keys[b].frame; });
    for (size_t i = 1; i < order.size(); ++i) {
      if (keys[order[i]].frame == keys[order[i - 1]].frame) {
        const size_t later = std::max(order[i], order[i - 1]);
        const size_t earlier = std::min(order[i], order[i - 1]);
        Fail(PointerChild(paths[later], "frame"), "duplicate keyframe at frame " +
                                                      std::to_string(keys[later].frame) + " (also at " +
                                                      paths[earlier] + ")");
      }
    }
    std::vector<Key> sortedKeys;
    std::vector<std::string> sortedPaths;
    for (size_t i : order) {
      sortedKeys.push_back(keys[i]);
      sortedPaths.push_back(paths[i]);
    }
    keys.swap(sortedKeys);
    paths.swap(sortedPaths);
  }

  void CheckUniqueName(std::map<std::string, std::string>& seen, const std::string& name,
                       const std::string& p, const std::string& what) const {
    auto [it, inserted] = seen.emplace(name, p);
    if (!inserted) Fail(p, "duplicate " + what + " name '" + name + "' (first used at " + it->second + ")");
  }

  void ReadMaterials(const Json& list, const std::string& p, Sequence& seq);
  void ReadObjects(const Json& list, const std::string& p, Sequence& seq);
  // The index in seq.materials of the material `value` names (a string at `p`); an unknown name is an error there,
  // with the nearest name suggested.
  uint32_t MaterialNamed(const Json& value, const std::string& p, const Sequence& seq) const;
  // A light's `material` (Light::material), or -1 where it gives none.
  int32_t ReadLightMaterial(const Json& light, const std::string& lp, const Sequence& seq) const;
  Mesh ReadShape(const Json& shape, const std::string& p);
  ImportedAsset LoadAsset(const std::string& file, const std::string& p);
  void ReadAssetObject(const Json& o, const std::string& op, const std::string& name, Sequence& seq);
  std::vector<TransformKey> ReadTransformKeys(const Json& list, const std::string& p);
  void ReadLights(const Json& list, const std::string& p, Sequence& seq);
  void AddLight(Sequence& seq, std::string name, const std::vector<Vec3>& vertices, const Vec3& radiance,
                const std::vector<std::pair<int, int>>& onRanges, const std::string& p);
  // `what` names the switched thing in the message for an empty list ("a light", "the sun").
  std::vector<std::pair<int, int>> ReadOnRanges(const Json& v, const std::string& p,
                                                const std::string& what = "a light") const;
  // sim/scene/sequence_sky.cpp
  void ReadEnvironment(const Json& environment, const std::string& p, Sequence& seq);
  EnvironmentMap LoadEnvironmentMap(const std::string& file, const std::string& p);
  void ReadSun(const Json& sun, const std::string& p, Sequence& seq);
  float SkyIntensity(const Json& v, const std::string& p) const;
  Vec3 SunDirection(const Json& v, const std::string& p) const;
  void ReadCamera(const Json& camera, const std::string& p, Sequence& seq);
  void ReadRender(const Json& render, const std::string& p, Sequence& seq);

  std::string baseDir_;
  uint64_t hash_;
  uint64_t seqSkippedPrimitives_ = 0;
  int frameCount_ = 1;
  size_t sceneTriangles_ = 0;
  std::map<std::string, std::string> lightNames_;
  std::unordered_map<std::string, ImportedAsset> assetCache_;  // resolved path → asset, so a file is imported once
};

// The `validate` lines of the environment and the sun (sim/scene/sequence_sky.cpp); "" when there is neither.
std::string SummarizeSky(const Sequence& sequence);

}  // namespace sequence_internal
}  // namespace restir
