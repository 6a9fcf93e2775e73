#include "sim/scene/sequence_assets.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "sim/scene/animation.h"

namespace restir {

namespace {

// Perceptual roughness below this is treated as this: alpha = 0.0025 still gives a finite GGX lobe that the
// estimators can sample, where alpha = 0 would be a mirror the simulator does not model.
constexpr float kMinRoughness = 0.05f;

Vec3 Clamp01(const Vec3& v) { return glm::clamp(v, Vec3(0.0f), Vec3(1.0f)); }

Material ToMaterial(const AssetMaterial& a, const std::string& name, int32_t texture) {
  Material m;
  m.name = name;
  m.type = MaterialType::kLayered;
  m.albedo = Clamp01(a.baseColor);
  m.metallic = std::clamp(a.metallic, 0.0f, 1.0f);
  m.roughness = std::clamp(a.roughness, kMinRoughness, 1.0f);
  m.specular = std::clamp(a.specular, 0.0f, 1.0f);
  m.baseColorTexture = texture;
  return m;
}

// The same test as the reader's for sequence lights: an absolute floor for tiny triangles, a relative one for
// collinear corners of any size.
bool HasArea(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a;
  const float twiceArea = glm::length(glm::cross(e1, e2));
  return twiceArea > 1e-12f && twiceArea > 1e-7f * glm::length(e1) * glm::length(e2);
}

}  // namespace

void AddAsset(ImportedAsset asset, const AssetPlacement& place, const AssetBudget& budget, Sequence& seq,
              const std::function<void(const std::string&)>& fail) {
  const Mat4 toWorld = TransformMatrix(place.keys.at(0).translate, place.keys[0].rotateDegrees, place.keys[0].scale);
  std::set<std::string> names;
  for (const Material& m : seq.materials) names.insert(m.name);
  for (const Object& o : seq.objects) names.insert("object:" + o.name);
  for (const Light& l : seq.lights) names.insert("light:" + l.name);

  // Materials and base-colour textures, each added once and only when a mesh uses it.
  std::vector<int32_t> materialIndex(asset.materials.size(), -1);
  std::vector<int32_t> textureIndex(asset.textures.size(), -1);
  auto materialOf = [&](uint32_t k) -> uint32_t {
    if (place.material >= 0) return static_cast<uint32_t>(place.material);
    if (materialIndex[k] < 0) {
      const AssetMaterial& a = asset.materials[k];
      int32_t tex = -1;
      if (a.baseColorTexture >= 0) {
        int32_t& t = textureIndex[size_t(a.baseColorTexture)];
        if (t < 0) {
          t = static_cast<int32_t>(seq.textures.size());
          seq.textures.push_back(asset.textures[size_t(a.baseColorTexture)]);
        }
        tex = t;
      }
      const std::string name = place.name + "/" + std::to_string(k) + (a.name.empty() ? "" : ":" + a.name);
      if (!names.insert(name).second) fail("the asset's material '" + name + "' collides with a material of that name");
      materialIndex[k] = static_cast<int32_t>(seq.materials.size());
      seq.materials.push_back(ToMaterial(a, name, tex));
    }
    return static_cast<uint32_t>(materialIndex[k]);
  };

  size_t sceneTriangles = 0, emitterTriangles = 0;
  for (const Object& o : seq.objects) sceneTriangles += o.mesh.triangles.size();
  for (const Light& l : seq.lights) emitterTriangles += l.vertices.size() / 3;

  for (size_t i = 0; i < asset.meshes.size(); ++i) {
    AssetMesh& am = asset.meshes[i];
    const AssetMaterial& material = asset.materials[am.material];
    const std::string base = place.name + "/" + std::to_string(i) + (am.name.empty() ? "" : ":" + am.name);
    const Vec3 emission = material.emission * place.emissionScale;
    const bool emits = place.emissionScale > 0.0f && std::max({emission.x, emission.y, emission.z}) > 0.0f;
    Mesh mesh;
    mesh.positions = std::move(am.positions);
    if (!am.normals.empty()) mesh.normals = std::move(am.normals);
    if (!am.texcoords.empty()) mesh.texcoords = std::move(am.texcoords);
    if (!emits) {
      mesh.triangles = std::move(am.triangles);
    } else {
      if (place.animated)
        fail("mesh '" + base + "' emits light, but the object is animated: moving emitters are not modelled "
             "(give the object one key, or set \"emissionScale\": 0)");
      // Each emissive triangle becomes a light triangle, in world space under the (single) key; it leaves the
      // object's geometry, since emitters are their own geometry (sim/scene/embree_scene.h).
      const Texture* tex = material.emissionTexture >= 0 ? &asset.textures[size_t(material.emissionTexture)] : nullptr;
      Light light;
      light.name = base + "/emission";
      light.radiance = emission;
      for (const glm::uvec3& t : am.triangles) {
        Vec3 w[3];
        for (int k = 0; k < 3; ++k) w[k] = Vec3(toWorld * Vec4(mesh.positions[t[k]], 1.0f));
        if (!HasArea(w[0], w[1], w[2])) {
          ++seq.skippedZeroAreaEmitters;
          continue;
        }
        Vec3 radiance = emission;
        if (tex) {
          const std::vector<Vec2>& uvs = am.emissionTexcoords.empty() ? mesh.texcoords : am.emissionTexcoords;
          radiance *= !uvs.empty() ? MeanOverTriangle(*tex, uvs[t.x], uvs[t.y], uvs[t.z])
                                   : SampleBilinear(*tex, 0.0f, 0.0f);
        }
        if (!(std::max({radiance.x, radiance.y, radiance.z}) > 0.0f)) {
          ++seq.skippedDarkEmitters;
          continue;
        }
        if (!(std::max({radiance.x, radiance.y, radiance.z}) <= budget.maxRadiance))
          fail("mesh '" + base + "' emits radiance beyond the limit of 1e12");
        for (const Vec3& q : w)
          if (!(std::max({std::fabs(q.x), std::fabs(q.y), std::fabs(q.z)}) <= budget.maxWorldExtent))
            fail("mesh '" + base + "' has an emitter beyond the limit of 1e8 m from the origin");
        light.vertices.insert(light.vertices.end(), {w[0], w[1], w[2]});
        light.triangleRadiance.push_back(radiance);
      }
      emitterTriangles += light.triangleRadiance.size();
      if (emitterTriangles > budget.maxEmitterTriangles)
        fail("the emissive triangles so far number " + std::to_string(emitterTriangles) +
             ", more than the scene limit of " + std::to_string(budget.maxEmitterTriangles));
      if (!light.vertices.empty()) {
        if (!names.insert("light:" + light.name).second) fail("light name '" + light.name + "' is already used");
        // One radiance for all when they agree, so `validate` and the light list stay as for a sequence light.
        if (std::all_of(light.triangleRadiance.begin(), light.triangleRadiance.end(),
                        [&](const Vec3& r) { return r == light.triangleRadiance[0]; })) {
          light.radiance = light.triangleRadiance[0];
          light.triangleRadiance.clear();
        }
        seq.lights.push_back(std::move(light));
      }
      continue;  // an emissive mesh is all emitter
    }
    sceneTriangles += mesh.triangles.size();
    if (sceneTriangles > budget.maxSceneTriangles)
      fail("the objects so far hold " + std::to_string(sceneTriangles) + " triangles, more than the scene limit of " +
           std::to_string(budget.maxSceneTriangles));
    Object obj;
    obj.name = base;
    if (!names.insert("object:" + obj.name).second) fail("object name '" + obj.name + "' is already used");
    obj.material = materialOf(am.material);
    obj.keys = place.keys;
    obj.animated = place.animated;
    obj.mesh = std::move(mesh);
    seq.objects.push_back(std::move(obj));
  }
}

Mesh MergeAssetMeshes(const ImportedAsset& asset) {
  Mesh out;
  bool normals = true;
  for (const AssetMesh& m : asset.meshes) normals = normals && !m.normals.empty();
  for (const AssetMesh& m : asset.meshes) {
    const uint32_t base = static_cast<uint32_t>(out.positions.size());
    out.positions.insert(out.positions.end(), m.positions.begin(), m.positions.end());
    if (normals) out.normals.insert(out.normals.end(), m.normals.begin(), m.normals.end());
    for (const glm::uvec3& t : m.triangles) out.triangles.push_back(t + glm::uvec3(base));
  }
  return out;
}

}  // namespace restir
