// A frame made by hand for calling one pass alone (issue 15): a G-buffer written pixel by pixel (no primary rays),
// an Embree scene holding only what shadow rays must see (a quad light, and an occluder when asked), the light
// sampler, the materials and the FrameView that ties them together. Every pixel is a point of the floor y = 0
// under the light, so p̂ and visibility are known in closed form.
#pragma once

#include <memory>
#include <vector>

#include "core/bsdf.h"
#include "core/light_sampler.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/estimator/passes/frame_view.h"
#include "sim/scene/sequence.h"

namespace restir::test {

struct HandMadeFrame {
  // W x H floor pixels 5 cm apart around the origin, a 0.5 m square light 1 m up emitting down; with `occluder`,
  // an opaque sheet at 0.5 m covering x < 0, so pixels with x < -0.3 see none of the light.
  HandMadeFrame(int width, int height, bool occluder = false) {
    Material m;
    m.name = "floor";
    m.albedo = Vec3(0.5f);
    sequence.materials.push_back(m);
    if (occluder) {
      Object o;
      o.name = "sheet";
      o.mesh.positions = {Vec3(-5, 0.5f, -5), Vec3(0, 0.5f, -5), Vec3(0, 0.5f, 5), Vec3(-5, 0.5f, 5)};
      o.mesh.triangles = {glm::uvec3(0, 1, 2), glm::uvec3(0, 2, 3)};
      o.keys.push_back(TransformKey{});
      sequence.objects.push_back(o);
    }
    Light l;
    l.name = "light";
    const Vec3 a(-0.25f, 1, -0.25f), b(0.25f, 1, -0.25f), c(0.25f, 1, 0.25f), d(-0.25f, 1, 0.25f);
    l.vertices = {a, b, c, a, c, d};  // counter-clockwise seen from below: emits down
    l.radiance = Vec3(4.0f);
    sequence.lights.push_back(l);
    state.objectToWorld.assign(sequence.objects.size(), Mat4(1.0f));
    state.lightOn = {1};
    state.camera.position = Vec3(0.0f, 3.0f, 0.0f);
    scene = std::make_unique<EmbreeScene>(sequence);
    scene->Update(state);
    lights = std::make_unique<LightSampler>(scene->LightTriangles(), LightSelection::kPower);
    materials = MakeBsdfSoa({Bsdf{BsdfType::kDiffuse, Vec3(0.5f), 0.0f}});

    gbuffer.Resize(width, height);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) SetFloorPixel(gbuffer, x, y);
    previous = gbuffer;
    for (size_t i = 0; i < gbuffer.Size(); ++i) {  // every pixel reprojects onto itself
      const int x = static_cast<int>(i % width), y = static_cast<int>(i / width);
      gbuffer.prevX[i] = x + 0.5f, gbuffer.prevY[i] = y + 0.5f, gbuffer.prevValid[i] = 1;
    }
  }

  // A floor point: x and z 5 cm apart, centred on the origin; object 0 (or 1 with an occluder: the floor is
  // not in the scene, only in the G-buffer), material 0, facing up.
  void SetFloorPixel(GBuffer& g, int x, int y) const {
    const size_t i = static_cast<size_t>(y) * g.width + x;
    const Vec3 p = FloorPoint(g, x, y);
    g.posX[i] = p.x, g.posY[i] = p.y, g.posZ[i] = p.z;
    g.ngX[i] = 0, g.ngY[i] = 1, g.ngZ[i] = 0;
    g.nsX[i] = 0, g.nsY[i] = 1, g.nsZ[i] = 0;
    g.errorScale[i] = std::max(std::fabs(p.x), std::fabs(p.z));
    g.objectId[i] = 7;
    g.materialId[i] = 0;
    g.bsdfId[i] = 0;
    g.lightId[i] = -1;
    g.depth[i] = 3.0f;
  }
  static Vec3 FloorPoint(const GBuffer& g, int x, int y) {
    return Vec3(0.05f * (x - 0.5f * (g.width - 1)), 0.0f, 0.05f * (y - 0.5f * (g.height - 1)));
  }

  // The view a pass reads; with history, `previous` is the previous frame (same state).
  FrameView View(uint32_t seed = 1, uint32_t frame = 1, bool history = false) {
    FrameView v;
    v.gbuffer = &gbuffer;
    v.previousGbuffer = history ? &previous : nullptr;
    v.scene = scene.get();
    v.lights = lights.get();
    v.previousLights = history ? &scene->LightTriangles() : nullptr;
    v.eye = state.camera.position;
    v.previousEye = state.camera.position;
    v.materials = &materials;
    v.seed = seed;
    v.frame = frame;
    return v;
  }

  Sequence sequence;
  FrameState state;
  std::unique_ptr<EmbreeScene> scene;
  std::unique_ptr<LightSampler> lights;
  BsdfSoa materials;
  GBuffer gbuffer, previous;
};

}  // namespace restir::test
