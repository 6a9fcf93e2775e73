// Sequence files (DESIGN §8): JSON → validated Sequence, evaluation of the animation at a frame, and the
// `validate` summary. Every problem becomes one InputError line "file:line:col: error at /json/path: what"
// (DESIGN §10); the format itself is documented in docs/sequence-format.md. The environment and the sun are read in
// sim/scene/sequence_sky.cpp.
#include "sim/scene/sequence.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string_view>
#include <unordered_map>

#include "sim/scene/animation.h"
#include "sim/util/hash.h"
#include "sim/util/input_file.h"
#include "sim/util/json_reader.h"
#include "sim/assets/asset_import.h"
#include "sim/scene/sequence_assets.h"
#include "sim/scene/sequence_reader.h"
#include "sim/scene/shapes.h"
#include "sim/util/text.h"

namespace restir {
namespace sequence_internal {

Sequence Reader::Read(const Json& root) {
  Sequence seq;
  AsObject(root, "");
  CheckKeys(root, "",
            {"name", "description", "resolution", "frames", "frameRate", "seed", "materials", "objects",
             "lights", "environment", "sun", "camera", "render"});
  seq.name = Name(Need(root, "", "name"), "/name");
  if (const Json* v = Find(root, "description")) seq.description = String(*v, "/description");

  const Json& res = Need(root, "", "resolution");
  if (!res.is_array() || res.size() != 2) {
    Fail("/resolution", "expected [width, height], got " +
                            (res.is_array() ? "an array of " + std::to_string(res.size()) : JsonTypeName(res)));
  }
  seq.width = static_cast<int>(Integer(res[0], "/resolution/0", 1, 16384, "width"));
  seq.height = static_cast<int>(Integer(res[1], "/resolution/1", 1, 16384, "height"));
  seq.frameCount = static_cast<int>(Integer(Need(root, "", "frames"), "/frames", 1, 100000, "frames"));
  frameCount_ = seq.frameCount;
  if (const Json* v = Find(root, "frameRate")) {
    seq.frameRate = Float(*v, "/frameRate");
    if (!(seq.frameRate > 0.0f && seq.frameRate <= 1000.0f)) {
      Fail("/frameRate", "frameRate must be in (0, 1000], got " + FormatNumber(seq.frameRate));
    }
  }
  if (const Json* v = Find(root, "seed"))
    seq.seed = static_cast<uint32_t>(Integer(*v, "/seed", 0, 4294967295ll, "seed"));

  // A scene made only of assets brings its materials with them; any other object needs a sequence material.
  const Json& materials = AsArray(Need(root, "", "materials"), "/materials", false);
  if (materials.empty()) {
    const Json& objects = Need(root, "", "objects");
    bool onlyAssets = objects.is_array() && !objects.empty();
    if (onlyAssets)
      for (const Json& o : objects) onlyAssets = onlyAssets && o.is_object() && o.contains("asset");
    if (!onlyAssets) Fail("/materials", "expected a non-empty array (only a scene made entirely of assets may leave it empty)");
  }
  ReadMaterials(materials, "/materials", seq);
  ReadObjects(AsArray(Need(root, "", "objects"), "/objects", true), "/objects", seq);
  if (const Json* v = Find(root, "environment")) ReadEnvironment(AsObject(*v, "/environment"), "/environment", seq);
  if (const Json* v = Find(root, "sun")) ReadSun(AsObject(*v, "/sun"), "/sun", seq);
  // Light may come from assets' emissive surfaces or from the sky instead; the scene needs some either way.
  const Json& lights = AsArray(Need(root, "", "lights"), "/lights", false);
  if (lights.empty() && seq.lights.empty() && !seq.environment.present && !seq.sun.present)
    Fail("/lights", "expected a non-empty array (lights may be empty only when assets bring emitters or there is "
                    "an environment or a sun)");
  ReadLights(lights, "/lights", seq);
  ReadCamera(AsObject(Need(root, "", "camera"), "/camera"), "/camera", seq);
  if (const Json* v = Find(root, "render")) ReadRender(AsObject(*v, "/render"), "/render", seq);
  seq.contentHash = Hash();
  seq.skippedPrimitives = seqSkippedPrimitives_;
  return seq;
}

void Reader::ReadMaterials(const Json& list, const std::string& p, Sequence& seq) {
  std::map<std::string, std::string> names;
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string mp = PointerChild(p, i);
    const Json& m = AsObject(list[i], mp);
    CheckKeys(m, mp, {"name", "type", "albedo", "roughness"});
    Material mat;
    mat.name = Name(Need(m, mp, "name"), mp + "/name");
    CheckUniqueName(names, mat.name, mp + "/name", "material");
    mat.type = Choice(Need(m, mp, "type"), mp + "/type", "material type", {"diffuse", "ggx"}) == 0
                   ? MaterialType::kDiffuse
                   : MaterialType::kGgx;
    mat.albedo = Color(Need(m, mp, "albedo"), mp + "/albedo", "albedo", true);
    if (std::max({mat.albedo.x, mat.albedo.y, mat.albedo.z}) > 1.0f) {
      Fail(mp + "/albedo",
           "albedo components must be <= 1 (energy conservation), got " + FormatVec(mat.albedo));
    }
    if (const Json* r = Find(m, "roughness")) {
      if (mat.type != MaterialType::kGgx)
        Fail(mp + "/roughness", "roughness applies only to 'ggx' materials");
      mat.roughness = Float(*r, mp + "/roughness");
      if (!(mat.roughness > 0.0f && mat.roughness <= 1.0f)) {
        Fail(mp + "/roughness", "roughness must be in (0, 1], got " + FormatNumber(mat.roughness));
      }
    }
    seq.materials.push_back(mat);
  }
}

uint32_t Reader::MaterialNamed(const Json& value, const std::string& p, const Sequence& seq) const {
  const std::string material = String(value, p);
  std::vector<std::string> names;
  for (const Material& m : seq.materials) names.push_back(m.name);
  const auto it = std::find(names.begin(), names.end(), material);
  if (it == names.end()) Fail(p, "unknown material '" + material + "'" + Suggestion(material, names));
  return static_cast<uint32_t>(it - names.begin());
}

void Reader::ReadObjects(const Json& list, const std::string& p, Sequence& seq) {
  std::map<std::string, std::string> names;
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string op = PointerChild(p, i);
    const Json& o = AsObject(list[i], op);
    CheckKeys(o, op, {"name", "material", "shape", "asset", "keyframes"});
    Object obj;
    obj.name = Name(Need(o, op, "name"), op + "/name");
    CheckUniqueName(names, obj.name, op + "/name", "object");
    if (Find(o, "asset")) {
      if (Find(o, "shape")) Fail(op + "/asset", "give either 'shape' or 'asset', not both");
      ReadAssetObject(o, op, obj.name, seq);
      continue;
    }
    obj.material = MaterialNamed(Need(o, op, "material"), op + "/material", seq);
    obj.mesh = ReadShape(AsObject(Need(o, op, "shape"), op + "/shape"), op + "/shape");
    sceneTriangles_ += obj.mesh.triangles.size();
    if (sceneTriangles_ > kMaxSceneTriangles) {
      Fail(op + "/shape", "the objects so far hold " + std::to_string(sceneTriangles_) +
                              " triangles, more than the scene limit of " + std::to_string(kMaxSceneTriangles));
    }
    if (const Json* k = Find(o, "keyframes")) {
      obj.keys = ReadTransformKeys(AsArray(*k, op + "/keyframes", true), op + "/keyframes");
    } else {
      obj.keys.push_back(TransformKey{});
    }
    double radius = 0.0;  // the mesh's extent from the object-space origin
    for (const Vec3& v : obj.mesh.positions) radius = std::max(radius, double(glm::length(v)));
    for (size_t k = 0; k < obj.keys.size(); ++k) {
      const TransformKey& key = obj.keys[k];
      if (key.translate != obj.keys[0].translate || key.rotateDegrees != obj.keys[0].rotateDegrees ||
          key.scale != obj.keys[0].scale) {
        obj.animated = true;
      }
      // Interpolation stays within the keys' translations and scales, so the keys bound every frame.
      const double scale = std::max({std::fabs(key.scale.x), std::fabs(key.scale.y), std::fabs(key.scale.z)});
      if (double(glm::length(key.translate)) + scale * radius > kMaxWorldExtent)
        Fail(PointerChild(op + "/keyframes", k), "the object reaches " + FormatNumber(glm::length(key.translate) +
                                                                                  scale * radius) +
                                                     " m from the origin under this key, beyond the limit of 1e8 m");
    }
    seq.objects.push_back(std::move(obj));
  }
}

Mesh Reader::ReadShape(const Json& shape, const std::string& p) {
  static const std::vector<std::string> kTypes = {"quad", "box", "sphere", "window_bars", "mesh"};
  const size_t type = Choice(Need(shape, p, "type"), p + "/type", "shape type", kTypes);
  Mesh mesh;
  auto vec = [&](const char* key) { return Vector(Need(shape, p, key), p + "/" + key); };
  auto positive = [&](const char* key) { return Positive(Need(shape, p, key), p + "/" + key, key); };
  switch (type) {
    case 0: {  // quad
      CheckKeys(shape, p, {"type", "center", "u", "v"});
      const Vec3 c = vec("center"), u = vec("u"), v = vec("v");
      if (!(glm::length(glm::cross(u, v)) > 0.0f)) Fail(p, "degenerate quad: u and v are zero or parallel");
      mesh = MakeQuad(c, u, v);
      break;
    }
    case 1: {  // box
      CheckKeys(shape, p, {"type", "min", "max"});
      const Vec3 lo = vec("min"), hi = vec("max");
      if (!(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z)) {
        Fail(p + "/max",
             "box max must exceed min on every axis, got min " + FormatVec(lo) + " max " + FormatVec(hi));
      }
      AppendBox(mesh, lo, hi);
      break;
    }
    case 2: {  // sphere
      CheckKeys(shape, p, {"type", "center", "radius", "segments"});
      const Vec3 c = vec("center");
      const float radius = positive("radius");
      int segments = 32;
      if (const Json* s = Find(shape, "segments")) {
        segments = static_cast<int>(Integer(*s, p + "/segments", 3, 1024, "segments"));
      }
      mesh = MakeSphere(c, radius, segments);
      break;
    }
    case 3: {  // window_bars
      CheckKeys(shape, p, {"type", "origin", "count", "spacing", "thickness", "height", "depth"});
      const Vec3 origin = vec("origin");
      const int count = static_cast<int>(Integer(Need(shape, p, "count"), p + "/count", 1, 10000, "count"));
      const float spacing = positive("spacing");
      const float thickness = positive("thickness");
      const float height = positive("height");
      const float depth = positive("depth");
      if (count > 1 && !(spacing > thickness)) {
        Fail(p + "/spacing", "spacing must exceed thickness so bars do not overlap, got spacing " +
                                 FormatNumber(spacing) + " thickness " + FormatNumber(thickness));
      }
      AppendWindowBars(mesh, origin, count, spacing, thickness, height, depth);
      break;
    }
    default: {  // mesh
      CheckKeys(shape, p, {"type", "file"});
      const std::string file = String(Need(shape, p, "file"), p + "/file");
      if (file.empty()) Fail(p + "/file", "mesh file name must not be empty");
      mesh = MergeAssetMeshes(LoadAsset(file, p + "/file"));
      break;
    }
  }
  return mesh;
}

// An asset or mesh file, resolved against the sequence's directory and imported once per run
// (sim/assets/asset_import.h).
// What it imports to (geometry, materials, decoded textures) enters the content hash, so an edit to the file or to
// a texture or buffer it references changes the hash, and so the reference cache key.
ImportedAsset Reader::LoadAsset(const std::string& file, const std::string& p) {
  namespace fs = std::filesystem;
  if (file.empty()) Fail(p, "file name must not be empty");
  fs::path resolved = fs::path(file);
  if (resolved.is_relative()) resolved = fs::path(baseDir_.empty() ? "." : baseDir_) / resolved;
  const std::string path = resolved.lexically_normal().string();
  if (auto it = assetCache_.find(path); it != assetCache_.end()) return it->second;
  std::string problem;
  if (!IsReadableRegularFile(path, kMaxMeshBytes, problem))
    Fail(p, "cannot read file '" + path + "' (" + problem + ")");
  if (!IsSupportedAssetExtension(fs::path(path).extension().string()))
    Fail(p, "'" + path + "' is not a supported asset (supported: .gltf, .glb, .obj, .ply)");
  const SourcePos from = Position(p);
  ImportedAsset asset;
  try {
    asset = ImportAsset(path);
  } catch (const InputError& e) {
    throw InputError(OneLine(std::string(e.what()) + " (asset of " + File() + ":" + std::to_string(from.line) + ":" +
                             std::to_string(from.column) + " " + p + ")"));
  }
  const std::string imported = SerializeAsset(asset);
  hash_ = Fnv1a(imported.data(), imported.size(), hash_);
  seqSkippedPrimitives_ += asset.skippedPrimitives;
  return assetCache_.emplace(path, std::move(asset)).first->second;
}

void Reader::ReadAssetObject(const Json& o, const std::string& op, const std::string& name, Sequence& seq) {
  const std::string ap = op + "/asset";
  const Json& a = AsObject(Need(o, op, "asset"), ap);
  CheckKeys(a, ap, {"file", "emissionScale"});
  AssetPlacement place;
  place.name = name;
  if (const Json* k = Find(o, "keyframes"))
    place.keys = ReadTransformKeys(AsArray(*k, op + "/keyframes", true), op + "/keyframes");
  else
    place.keys.push_back(TransformKey{});
  for (const TransformKey& key : place.keys)
    place.animated = place.animated || key.translate != place.keys[0].translate ||
                     key.rotateDegrees != place.keys[0].rotateDegrees || key.scale != place.keys[0].scale;
  if (const Json* s = Find(a, "emissionScale")) {
    place.emissionScale = Float(*s, ap + "/emissionScale");
    if (!(place.emissionScale >= 0.0f)) Fail(ap + "/emissionScale", "emissionScale must be >= 0");
  }
  if (const Json* m = Find(o, "material"))
    place.material = static_cast<int32_t>(MaterialNamed(*m, op + "/material", seq));
  const ImportedAsset& asset = LoadAsset(String(Need(a, ap, "file"), ap + "/file"), ap + "/file");
  AssetBudget budget;
  budget.maxSceneTriangles = kMaxSceneTriangles;
  budget.maxEmitterTriangles = kMaxEmitterTriangles;
  budget.maxWorldExtent = kMaxWorldExtent;
  budget.maxRadiance = kMaxRadiance;
  const size_t objectsBefore = seq.objects.size(), lightsBefore = seq.lights.size();
  AddAsset(asset, place, budget, seq, [&](const std::string& what) { Fail(ap, what); });
  for (size_t l = lightsBefore; l < seq.lights.size(); ++l)
    CheckUniqueName(lightNames_, seq.lights[l].name, ap, "light");
  for (size_t i = objectsBefore; i < seq.objects.size(); ++i) {
    Object& obj = seq.objects[i];
    sceneTriangles_ += obj.mesh.triangles.size();
    double radius = 0.0;
    for (const Vec3& v : obj.mesh.positions) radius = std::max(radius, double(glm::length(v)));
    for (size_t k = 0; k < obj.keys.size(); ++k) {
      const TransformKey& key = obj.keys[k];
      const double scale = std::max({std::fabs(key.scale.x), std::fabs(key.scale.y), std::fabs(key.scale.z)});
      if (double(glm::length(key.translate)) + scale * radius > kMaxWorldExtent)
        Fail(PointerChild(op + "/keyframes", k), "the asset reaches " +
                                                     FormatNumber(glm::length(key.translate) + scale * radius) +
                                                     " m from the origin under this key, beyond the limit of 1e8 m");
    }
  }
}

std::vector<TransformKey> Reader::ReadTransformKeys(const Json& list, const std::string& p) {
  std::vector<TransformKey> keys;
  std::vector<std::string> paths;
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string kp = PointerChild(p, i);
    const Json& k = AsObject(list[i], kp);
    CheckKeys(k, kp, {"frame", "translate", "rotate", "scale", "interpolation"});
    TransformKey key;
    key.frame = ReadKeyFrame(k, kp);
    if (const Json* v = Find(k, "translate")) key.translate = Vector(*v, kp + "/translate");
    if (const Json* v = Find(k, "rotate")) key.rotateDegrees = Vector(*v, kp + "/rotate");
    if (const Json* v = Find(k, "scale")) {
      key.scale = v->is_number() ? Vec3(Float(*v, kp + "/scale")) : Vector(*v, kp + "/scale");
      if (!(key.scale.x > 0.0f && key.scale.y > 0.0f && key.scale.z > 0.0f)) {
        // Mirroring would flip triangle winding (and so which side counts as the front).
        Fail(kp + "/scale", "scale must be > 0 on every axis, got " + FormatVec(key.scale));
      }
    }
    key.interpolation = ReadInterpolation(k, kp);
    keys.push_back(key);
    paths.push_back(kp);
  }
  SortKeys(keys, paths);
  return keys;
}

std::vector<std::pair<int, int>> Reader::ReadOnRanges(const Json& v, const std::string& p,
                                                      const std::string& what) const {
  AsArray(v, p, false);
  if (v.empty())
    Fail(p, "'on' needs at least one [first, last) range (leave it out for " + what + " that is always on)");
  std::vector<std::pair<int, int>> ranges;
  for (size_t i = 0; i < v.size(); ++i) {
    const std::string rp = PointerChild(p, i);
    const Json& r = v[i];
    if (!r.is_array() || r.size() != 2) Fail(rp, "expected a [first, last) frame range");
    const int first = static_cast<int>(Integer(r[0], rp + "/0", 0, frameCount_ - 1, "first frame"));
    const int last = static_cast<int>(Integer(r[1], rp + "/1", 0, frameCount_, "last frame (exclusive)"));
    if (last <= first)
      Fail(rp, "empty range: last (" + std::to_string(last) + ") must exceed first (" +
                   std::to_string(first) + ")");
    ranges.emplace_back(first, last);
  }
  return ranges;
}

void Reader::AddLight(Sequence& seq, std::string name, const std::vector<Vec3>& vertices,
                      const Vec3& radiance, const std::vector<std::pair<int, int>>& onRanges,
                      const std::string& p) {
  if (seq.lights.size() >= kMaxLights) {
    Fail(p, "more than the scene limit of " + std::to_string(kMaxLights) + " lights");
  }
  if (std::max({radiance.x, radiance.y, radiance.z}) > kMaxRadiance)
    Fail(p, "light '" + name + "' has radiance (colour x intensity) " + FormatVec(radiance) +
                ", beyond the limit of 1e12 (products with it must stay finite in single precision)");
  for (const Vec3& q : vertices)
    if (std::max({std::fabs(q.x), std::fabs(q.y), std::fabs(q.z)}) > kMaxWorldExtent)
      Fail(p, "light '" + name + "' reaches " + FormatVec(q) + ", beyond the limit of 1e8 m from the origin");
  for (size_t t = 0; t + 2 < vertices.size(); t += 3) {
    const Vec3 e1 = vertices[t + 1] - vertices[t];
    const Vec3 e2 = vertices[t + 2] - vertices[t];
    const float twiceArea = glm::length(glm::cross(e1, e2));
    // Absolute floor for tiny emitters, relative one for collinear corners of any size.
    if (!(twiceArea > 1e-12f) || !(twiceArea > 1e-7f * glm::length(e1) * glm::length(e2))) {
      Fail(p, "zero-area light '" + name + "'");
    }
  }
  CheckUniqueName(lightNames_, name, p + "/name", "light");
  Light light;
  light.name = std::move(name);
  light.vertices = vertices;
  light.radiance = radiance;
  light.onRanges = onRanges;
  seq.lights.push_back(std::move(light));
}

// Emitters carry no texture coordinates, so a textured material (an asset's) would be read at one texel: refused.
int32_t Reader::ReadLightMaterial(const Json& light, const std::string& lp, const Sequence& seq) const {
  const Json* m = Find(light, "material");
  if (!m) return -1;
  const uint32_t index = MaterialNamed(*m, lp + "/material", seq);
  if (seq.materials[index].baseColorTexture >= 0)
    Fail(lp + "/material", "material '" + seq.materials[index].name +
                               "' has a base-colour texture, which a light cannot carry (emitters have no texture "
                               "coordinates)");
  return static_cast<int32_t>(index);
}

void Reader::ReadLights(const Json& list, const std::string& p, Sequence& seq) {
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string lp = PointerChild(p, i);
    const Json& l = AsObject(list[i], lp);
    const size_t type = Choice(Need(l, lp, "type"), lp + "/type", "light type", {"quad", "triangle", "grid"});
    const std::string name = Name(Need(l, lp, "name"), lp + "/name");
    auto vec = [&](const char* key) { return Vector(Need(l, lp, key), lp + "/" + key); };
    std::vector<std::pair<int, int>> on;
    if (const Json* v = Find(l, "on")) on = ReadOnRanges(*v, lp + "/on");
    auto radiance = [&](bool optional) {
      // For grids either may come from the cycled lists instead; white and 1 are then only placeholders.
      Vec3 color(1.0f);
      float intensity = 1.0f;
      if (const Json* c = optional ? Find(l, "color") : &Need(l, lp, "color")) {
        color = Color(*c, lp + "/color", "color", false);
      }
      if (const Json* k = optional ? Find(l, "intensity") : &Need(l, lp, "intensity")) {
        intensity = Intensity(*k, lp + "/intensity");
      }
      return color * intensity;
    };
    const int32_t material = ReadLightMaterial(l, lp, seq);
    const size_t first = seq.lights.size();
    if (type == 0) {  // quad
      CheckKeys(l, lp, {"name", "type", "center", "u", "v", "color", "intensity", "on", "material"});
      const Vec3 c = vec("center"), u = vec("u"), v = vec("v");
      const Vec3 rad = radiance(false);
      Vec3 q[4];
      QuadCorners(c, u, v, q);
      AddLight(seq, name, {q[0], q[1], q[2], q[0], q[2], q[3]}, rad, on, lp);
    } else if (type == 1) {  // triangle
      CheckKeys(l, lp, {"name", "type", "vertices", "color", "intensity", "on", "material"});
      const Json& vs = Need(l, lp, "vertices");
      if (!vs.is_array() || vs.size() != 3) Fail(lp + "/vertices", "expected an array of 3 points");
      std::vector<Vec3> tri;
      for (size_t k = 0; k < 3; ++k) tri.push_back(Vector(vs[k], PointerChild(lp + "/vertices", k)));
      const Vec3 rad = radiance(false);
      AddLight(seq, name, tri, rad, on, lp);
    } else {  // grid
      CheckKeys(l, lp,
                {"name", "type", "origin", "u", "v", "count", "pitch", "color", "colors", "intensity",
                 "intensities", "on", "material"});
      const Vec3 origin = vec("origin"), u = vec("u"), v = vec("v");
      const Json& count = Need(l, lp, "count");
      if (!count.is_array() || count.size() != 2) Fail(lp + "/count", "expected [nx, ny]");
      const int nx = static_cast<int>(Integer(count[0], lp + "/count/0", 1, 1024, "nx"));
      const int ny = static_cast<int>(Integer(count[1], lp + "/count/1", 1, 1024, "ny"));
      if (nx * ny > 65536) Fail(lp + "/count", "a grid may hold at most 65536 lights");
      if (seq.lights.size() + static_cast<size_t>(nx * ny) > kMaxLights) {
        Fail(lp + "/count", "this grid would bring the lights to " +
                                std::to_string(seq.lights.size() + static_cast<size_t>(nx * ny)) +
                                ", more than the scene limit of " + std::to_string(kMaxLights));
      }
      const Json& pitch = Need(l, lp, "pitch");
      if (!pitch.is_array() || pitch.size() != 2) {
        Fail(lp + "/pitch",
             "expected [pitchU, pitchV]: two numbers (distances along u and v) or two vectors");
      }
      Vec3 step[2];
      for (size_t k = 0; k < 2; ++k) {
        const std::string pp = PointerChild(lp + "/pitch", k);
        const Vec3& axis = k == 0 ? u : v;
        if (pitch[k].is_number()) {
          if (!(glm::length(axis) > 0.0f)) Fail(lp, "zero-area light '" + name + "'");
          step[k] = glm::normalize(axis) * Float(pitch[k], pp);
        } else {
          step[k] = Vector(pitch[k], pp);
        }
      }
      if (Find(l, "color") && Find(l, "colors"))
        Fail(lp + "/colors", "give either 'color' or 'colors', not both");
      if (Find(l, "intensity") && Find(l, "intensities")) {
        Fail(lp + "/intensities", "give either 'intensity' or 'intensities', not both");
      }
      if (!Find(l, "colors")) Need(l, lp, "color");
      if (!Find(l, "intensities")) Need(l, lp, "intensity");
      const Vec3 base = radiance(true);
      std::vector<Vec3> colors;
      std::vector<float> intensities;
      if (const Json* cs = Find(l, "colors")) {
        AsArray(*cs, lp + "/colors", true);
        for (size_t k = 0; k < cs->size(); ++k) {
          colors.push_back(Color((*cs)[k], PointerChild(lp + "/colors", k), "color", false));
        }
      }
      if (const Json* ks = Find(l, "intensities")) {
        AsArray(*ks, lp + "/intensities", true);
        for (size_t k = 0; k < ks->size(); ++k) {
          intensities.push_back(Intensity((*ks)[k], PointerChild(lp + "/intensities", k)));
        }
      }
      for (int j = 0; j < ny; ++j) {
        for (int i2 = 0; i2 < nx; ++i2) {
          const size_t index = static_cast<size_t>(j) * static_cast<size_t>(nx) + static_cast<size_t>(i2);
          Vec3 rad = base;
          if (!colors.empty()) rad = rad * colors[index % colors.size()];
          if (!intensities.empty()) rad = rad * intensities[index % intensities.size()];
          const Vec3 corner = origin + static_cast<float>(i2) * step[0] + static_cast<float>(j) * step[1];
          const Vec3 q[4] = {corner, corner + u, corner + u + v, corner + v};
          AddLight(seq, name + "[" + std::to_string(i2) + "," + std::to_string(j) + "]",
                   {q[0], q[1], q[2], q[0], q[2], q[3]}, rad, on, lp);
        }
      }
    }
    for (size_t k = first; k < seq.lights.size(); ++k) seq.lights[k].material = material;
  }
}

void Reader::ReadCamera(const Json& camera, const std::string& p, Sequence& seq) {
  CheckKeys(camera, p, {"keyframes"});
  const std::string lp = p + "/keyframes";
  const Json& list = AsArray(Need(camera, p, "keyframes"), lp, true);
  std::vector<std::string> paths;
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string kp = PointerChild(lp, i);
    const Json& k = AsObject(list[i], kp);
    CheckKeys(k, kp, {"frame", "position", "lookAt", "fov", "interpolation"});
    CameraKey key;
    key.frame = ReadKeyFrame(k, kp);
    key.position = Vector(Need(k, kp, "position"), kp + "/position");
    key.lookAt = Vector(Need(k, kp, "lookAt"), kp + "/lookAt");
    if (!(glm::length(key.lookAt - key.position) > kMinLookDistance)) {
      Fail(kp + "/lookAt", "camera lookAt equals its position " + FormatVec(key.position));
    }
    if (const Json* f = Find(k, "fov")) {
      key.vfovDegrees = Float(*f, kp + "/fov");
      if (!(key.vfovDegrees > 0.0f && key.vfovDegrees < 180.0f)) {
        Fail(kp + "/fov", "fov must be in (0, 180) degrees, got " + FormatNumber(key.vfovDegrees));
      }
    }
    key.interpolation = ReadInterpolation(k, kp);
    seq.cameraKeys.push_back(key);
    paths.push_back(kp);
  }
  SortKeys(seq.cameraKeys, paths);
  // Keys can be fine while the path between them passes position through lookAt (e.g. they swap places).
  // Each segment is interpolated on its own two keys (the same arithmetic as on the whole list), so the check
  // costs one step per frame rather than one search over every key per frame.
  for (size_t i = 0; i + 1 < seq.cameraKeys.size(); ++i) {
    const std::vector<CameraKey> segment = {seq.cameraKeys[i], seq.cameraKeys[i + 1]};
    for (int f = seq.cameraKeys[i].frame + 1; f < seq.cameraKeys[i + 1].frame; ++f) {
      const CameraKey k = InterpolateCamera(segment, f);
      if (!(glm::length(k.lookAt - k.position) > kMinLookDistance)) {
        Fail(paths[i], "the interpolated camera position meets its lookAt at frame " + std::to_string(f));
      }
    }
  }
}

void Reader::ReadRender(const Json& render, const std::string& p, Sequence& seq) {
  CheckKeys(render, p, {"presets", "referenceSpp", "referenceError", "referenceSppCap"});
  if (const Json* v = Find(render, "presets")) {
    AsArray(*v, p + "/presets", true);
    seq.defaults.presets.clear();
    for (size_t i = 0; i < v->size(); ++i) {
      const std::string pp = PointerChild(p + "/presets", i);
      const std::string name = String((*v)[i], pp);
      if (name.empty()) Fail(pp, "preset name must not be empty");
      if (std::find(seq.defaults.presets.begin(), seq.defaults.presets.end(), name) !=
          seq.defaults.presets.end()) {
        Fail(pp, "preset '" + name + "' is listed twice");
      }
      seq.defaults.presets.push_back(name);
    }
  }
  if (const Json* v = Find(render, "referenceSpp")) {
    seq.defaults.referenceSpp =
        static_cast<int>(Integer(*v, p + "/referenceSpp", 1, 1 << 20, "referenceSpp"));
  }
  if (const Json* v = Find(render, "referenceError")) {
    const double e = Number(*v, p + "/referenceError");
    if (!(e >= 1e-4 && e <= 1.0))
      Fail(p + "/referenceError", "referenceError must be a relative standard error in [0.0001, 1], got " +
                                      FormatNumber(e));
    seq.defaults.referenceError = e;
  }
  if (const Json* v = Find(render, "referenceSppCap")) {
    if (!Find(render, "referenceError")) Fail(p + "/referenceSppCap", "referenceSppCap needs referenceError");
    // The pilot's 16 samples and one per replicate are the least any pixel takes.
    seq.defaults.referenceSppCap =
        static_cast<int>(Integer(*v, p + "/referenceSppCap", 32, 1 << 20, "referenceSppCap"));
  }
}

}  // namespace sequence_internal

Sequence ParseSequence(const std::string& text, const std::string& path, const std::string& baseDir) {
  sequence_internal::Reader reader(path, text, baseDir);
  Sequence seq = reader.Read(reader.Root());
  seq.path = path;
  return seq;
}

Sequence LoadSequence(const std::string& path) {
  namespace fs = std::filesystem;
  const std::string text = ReadInputFile(path, sequence_internal::kMaxSequenceBytes, "sequence file");
  std::string baseDir = fs::path(path).parent_path().string();
  if (baseDir.empty()) baseDir = ".";
  return ParseSequence(text, path, baseDir);
}

std::string SummarizeSequence(const Sequence& seq) {
  std::ostringstream out;
  char buf[256];
  out << seq.name << "  (" << seq.path << ", hash " << seq.contentHash << ")\n";
  if (!seq.description.empty()) out << "  " << seq.description << "\n";
  std::snprintf(buf, sizeof(buf), "resolution  %dx%d, %d frames at %g fps (%.2f s), seed %u\n", seq.width,
                seq.height, seq.frameCount, seq.frameRate, seq.frameCount / seq.frameRate, seq.seed);
  out << buf;

  out << "materials   " << seq.materials.size() << ":";
  size_t shown = 0;
  for (const Material& m : seq.materials) {
    // An asset brings a material per mesh; the first few name the kinds, the count says the rest.
    if (++shown > 12) {
      out << " ... (" << seq.materials.size() - 12 << " more)";
      break;
    }
    out << " " << m.name
        << (m.type == MaterialType::kGgx ? " (ggx)" : m.type == MaterialType::kLayered ? " (layered)" : " (diffuse)");
    if (m.baseColorTexture >= 0) out << "[textured]";
  }
  out << "\n";
  if (!seq.textures.empty()) out << "textures    " << seq.textures.size() << "\n";
  if (seq.skippedPrimitives || seq.skippedZeroAreaEmitters || seq.skippedDarkEmitters)
    out << "skipped     " << seq.skippedPrimitives << " points and lines, " << seq.skippedZeroAreaEmitters
        << " zero-area emissive triangles, " << seq.skippedDarkEmitters << " black emissive triangles\n";

  size_t triangles = 0, animated = 0;
  for (const Object& o : seq.objects) {
    triangles += o.mesh.triangles.size();
    animated += o.animated ? 1 : 0;
  }
  out << "objects     " << seq.objects.size() << " (" << animated << " animated), " << triangles
      << " triangles\n";
  for (const Object& o : seq.objects) {
    std::snprintf(buf, sizeof(buf), "  %-22s %-14s %7zu tris  %s\n", o.name.c_str(),
                  seq.materials[o.material].name.c_str(), o.mesh.triangles.size(),
                  o.animated ? "animated" : "static");
    out << buf;
    if (&o - seq.objects.data() >= 40 && seq.objects.size() > 41) {
      out << "  ... " << seq.objects.size() - 41 << " more objects\n";
      break;
    }
  }

  // Grid generators name their lights group[i,j]: summarise per group so the screen stays short.
  std::vector<std::string> groups;
  std::map<std::string, std::pair<size_t, double>> groupStats;  // lights, power
  size_t emitters = 0, switched = 0;
  double totalPower = 0.0;
  for (const Light& l : seq.lights) {
    double power = 0.0;
    for (size_t t = 0; t + 2 < l.vertices.size(); t += 3) {
      const float area = 0.5f * glm::length(glm::cross(l.vertices[t + 1] - l.vertices[t],
                                                       l.vertices[t + 2] - l.vertices[t]));
      const Vec3& radiance = l.triangleRadiance.empty() ? l.radiance : l.triangleRadiance[t / 3];
      power += kPi * area * Luminance(radiance);  // one-sided Lambertian emitter: Φ = π L A
      ++emitters;
    }
    totalPower += power;
    switched += l.onRanges.empty() ? 0 : 1;
    const std::string group = l.name.substr(0, l.name.find('['));
    auto [it, inserted] = groupStats.emplace(group, std::make_pair(size_t(0), 0.0));
    if (inserted) groups.push_back(group);
    it->second.first += 1;
    it->second.second += power;
  }
  std::snprintf(buf, sizeof(buf),
                "lights      %zu in %zu groups, %zu emitter triangles, %zu switched, total power %.4g W\n",
                seq.lights.size(), groups.size(), emitters, switched, totalPower);
  out << buf;
  for (const std::string& g : groups) {
    const size_t n = groupStats[g].first;
    std::snprintf(buf, sizeof(buf), "  %-22s %4zu light%s %10.4g W\n", g.c_str(), n, n == 1 ? " " : "s",
                  groupStats[g].second);
    out << buf;
  }

  out << sequence_internal::SummarizeSky(seq);

  double pathLength = 0.0;
  float fovMin = 180.0f, fovMax = 0.0f;
  for (int f = 0; f < seq.frameCount && !seq.cameraKeys.empty(); ++f) {
    const CameraKey k = InterpolateCamera(seq.cameraKeys, f);
    fovMin = std::min(fovMin, k.vfovDegrees);
    fovMax = std::max(fovMax, k.vfovDegrees);
    if (f > 0) pathLength += glm::length(k.position - InterpolateCamera(seq.cameraKeys, f - 1).position);
  }
  std::snprintf(buf, sizeof(buf), "camera      %zu keys, path length %.3f m, vertical fov %g..%g deg\n",
                seq.cameraKeys.size(), pathLength, fovMin, fovMax);
  out << buf;
  if (seq.defaults.referenceError > 0.0) {
    out << "render      reference to " << sequence_internal::FormatNumber(seq.defaults.referenceError)
        << " relative standard error";
    if (seq.defaults.referenceSppCap > 0) out << ", at most " << seq.defaults.referenceSppCap << " spp";
    out << "; presets:";
  } else {
    out << "render      reference " << seq.defaults.referenceSpp << " spp; presets:";
  }
  for (const std::string& p : seq.defaults.presets) out << " " << p;
  out << "\n";
  return out.str();
}

}  // namespace restir
