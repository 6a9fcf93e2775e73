#include "sim/scene/embree_scene.h"

// RawHit and OcclusionApi; the probe's functions are defined below only with RESTIR_RAY_HOOKS.
#include "sim/scene/embree_probe.h"

#include <embree3/rtcore.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

namespace restir {

namespace {

// Embree selects its kernels per ISA, and the AVX2/AVX-512 triangle and box tests are compiled with FMA while
// the SSE kernels are not; all of them divide through an approximate reciprocal whose last bits differ between
// CPU vendors. So Embree's t, u, v differ in the last bits from machine to machine, and the simulator takes only
// which triangle was hit (and whether a shadow ray is blocked) from it: SurfaceHit's attributes are recomputed
// in double (EmbreeScene::Intersect), and shadow rays keep a margin of float error from every surface they
// start or end on (core/shadow_ray.h). The ISA still defaults to SSE4.2, which every x86-64 CPU this runs on
// supports. Thread count is deliberately NOT set here: Embree's "threads=N" installs a process-wide
// tbb::global_control that would throttle every TBB pass of the simulator; builds are serialised per commit
// instead (see CommitSerial).
std::atomic<EmbreeIsa> gEmbreeIsa{EmbreeIsa::kSse42};

std::string DeviceConfig(EmbreeIsa isa) { return std::string("isa=") + EmbreeIsaName(isa); }

// Embree's parallel builders partition primitives into a number of tasks that depends on the arena's
// concurrency, so the leaf order (hence which of two primitives at exactly the same t wins) could depend on the
// machine's core count. Committing inside a one-thread arena makes the BVH a function of the input only. The
// scenes are small (prototypes are built once, the per-frame commit only covers a handful of instances), so the
// lost build parallelism does not matter.
void CommitSerial(RTCScene scene) {
  tbb::task_arena arena(1);
  arena.execute([&] { rtcCommitScene(scene); });
}

// ROBUST: Embree otherwise may use intersection tests that miss rays through shared edges and vertices, which
// would let light leak through the seams of a closed box (window bars); robust mode also makes the box tests
// conservative, so only the triangle test decides a hit. Build quality stays at the default: quality changes
// the tree, not the per-triangle test, so it only matters for exact ties, which the serial build pins anyway.
RTCScene NewScene(RTCDevice device) {
  RTCScene scene = rtcNewScene(device);
  rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
  return scene;
}

void ThrowOnDeviceError(RTCDevice device, const char* what) {
  const RTCError err = rtcGetDeviceError(device);
  if (err != RTC_ERROR_NONE) {
    throw std::runtime_error(std::string("Embree error ") + std::to_string(static_cast<int>(err)) + " while " +
                             what);
  }
}

// Triangle geometry from positions already in the space the geometry lives in.
RTCGeometry NewTriangleGeometry(RTCDevice device, const std::vector<Vec3>& positions,
                                const std::vector<glm::uvec3>& triangles) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  // Embree-owned buffers are padded for its SIMD loads, so nothing depends on the caller's allocation.
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                        3 * sizeof(float), positions.size()));
  auto* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(uint32_t), triangles.size()));
  if (v == nullptr || idx == nullptr) {
    rtcReleaseGeometry(geom);
    return nullptr;
  }
  for (size_t i = 0; i < positions.size(); ++i) {
    v[3 * i + 0] = positions[i].x;
    v[3 * i + 1] = positions[i].y;
    v[3 * i + 2] = positions[i].z;
  }
  for (size_t i = 0; i < triangles.size(); ++i) {
    idx[3 * i + 0] = triangles[i].x;
    idx[3 * i + 1] = triangles[i].y;
    idx[3 * i + 2] = triangles[i].z;
  }
  rtcCommitGeometry(geom);
  return geom;
}

glm::mat3 NormalMatrix(const Mat4& m) { return glm::transpose(glm::inverse(glm::mat3(m))); }

float MaxAbs(const glm::dvec3& v) { return static_cast<float>(std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)})); }

// The error scale of a hit on an instance, given its world-space vertices' (core/shadow_ray.h). Embree
// intersects an instance by moving the ray into object space with the inverse transform, in float: the
// object-space origin errs by about u (|o| + |translation|) in world units, times the transform's anisotropy
// (its largest axis scale over its smallest), which the inverse stretches unevenly. |o| is at most the
// vertices' scale for a ray spawned off this hit.
float InstanceErrorScale(const Mat4& m, float vertexScale) {
  const double s0 = glm::length(glm::dvec3(m[0])), s1 = glm::length(glm::dvec3(m[1])),
               s2 = glm::length(glm::dvec3(m[2]));
  const double smallest = std::min({s0, s1, s2}), largest = std::max({s0, s1, s2});
  const double anisotropy = smallest > 0.0 ? largest / smallest : 1.0;
  return static_cast<float>(anisotropy * (double(vertexScale) + double(MaxAbs(glm::dvec3(m[3])))));
}

// Where a ray meets the plane of triangle (p0, p1, p2), in double (Möller & Trumbore 1997): t along `dir`, and
// the barycentrics u of p1 and v of p2 (Embree's convention). False when the ray runs parallel to the plane.
bool IntersectPlane(const glm::dvec3& org, const glm::dvec3& dir, const glm::dvec3& p0, const glm::dvec3& p1,
                    const glm::dvec3& p2, double& t, double& u, double& v) {
  const glm::dvec3 e1 = p1 - p0, e2 = p2 - p0;
  const glm::dvec3 pv = glm::cross(dir, e2);
  const double det = glm::dot(e1, pv);
  if (!(std::fabs(det) > 0.0) || !std::isfinite(det)) return false;
  const glm::dvec3 tv = org - p0;
  const glm::dvec3 qv = glm::cross(tv, e1);
  u = glm::dot(tv, pv) / det;
  v = glm::dot(dir, qv) / det;
  t = glm::dot(e2, qv) / det;
  return std::isfinite(t) && std::isfinite(u) && std::isfinite(v);
}

Vec3 TransformPoint(const Mat4& m, const Vec3& p) { return Vec3(m * Vec4(p, 1.0f)); }

std::vector<LightTriangle> BuildLightTrianglesFrom(const std::vector<Light>& lights,
                                                   const std::vector<uint8_t>& lightOn,
                                                   std::vector<uint32_t>* groupOf) {
  std::vector<LightTriangle> out;
  if (groupOf) groupOf->clear();
  for (size_t l = 0; l < lights.size(); ++l) {
    const Light& light = lights[l];
    // A light missing from the state counts as on: only an explicit 0 switches it off.
    const bool on = l >= lightOn.size() || lightOn[l] != 0;
    for (size_t v = 0; v + 2 < light.vertices.size(); v += 3) {
      LightTriangle tri;
      const Vec3 radiance = light.triangleRadiance.empty() ? light.radiance : light.triangleRadiance[v / 3];
      if (!MakeLightTriangle(light.vertices[v], light.vertices[v + 1], light.vertices[v + 2],
                             on ? radiance : Vec3(0.0f), tri)) {
        // Load rejects degenerate lights; should one slip through, it still occupies its slot so that light
        // ids keep matching Embree's primIDs, but it can never be sampled.
        tri.normal = Vec3(0.0f);
        tri.area = 0.0f;
        tri.radiance = Vec3(0.0f);
      }
      out.push_back(tri);
      if (groupOf) groupOf->push_back(static_cast<uint32_t>(l));
    }
  }
  return out;
}

}  // namespace

namespace {

// Packets of N shadow rays (RTCRay4/8/16); lanes past the end or with tmax <= 0 are inactive.
template <int N, typename Packet, typename Trace>
void OccludedPackets(RTCScene scene, RTCIntersectContext& ctx, const ShadowRay* rays, uint8_t* occluded,
                     size_t count, Trace trace) {
  for (size_t base = 0; base < count; base += N) {
    alignas(64) Packet packet;
    alignas(64) int valid[N];
    const size_t lanes = std::min<size_t>(N, count - base);
    for (size_t i = 0; i < static_cast<size_t>(N); ++i) {
      const bool active = i < lanes && rays[base + i].tmax > 0.0f;
      const ShadowRay& r = rays[base + (i < lanes ? i : 0)];
      valid[i] = active ? -1 : 0;
      packet.org_x[i] = active ? r.org.x : 0.0f;
      packet.org_y[i] = active ? r.org.y : 0.0f;
      packet.org_z[i] = active ? r.org.z : 0.0f;
      packet.tnear[i] = 0.0f;
      packet.dir_x[i] = active ? r.dir.x : 0.0f;
      packet.dir_y[i] = active ? r.dir.y : 0.0f;
      packet.dir_z[i] = active ? r.dir.z : 1.0f;
      packet.time[i] = 0.0f;
      packet.tfar[i] = active ? r.tmax : 0.0f;
      packet.mask[i] = 0xffffffffu;
      packet.id[i] = static_cast<unsigned>(i);
      packet.flags[i] = 0;
    }
    trace(valid, scene, &ctx, &packet);
    for (size_t i = 0; i < lanes; ++i) {
      occluded[base + i] = valid[i] != 0 && packet.tfar[i] == -std::numeric_limits<float>::infinity() ? 1 : 0;
    }
  }
}

// OccludedPackets from arrays: the lanes are contiguous copies (the compiler vectorises a full packet's).
void OccludedPacketsSoa(RTCScene scene, RTCIntersectContext& ctx, const ShadowRaysSoa& rays, uint8_t* occluded) {
  constexpr size_t N = 4;
  for (size_t base = 0; base < rays.count; base += N) {
    alignas(16) RTCRay4 packet;
    alignas(16) int valid[N];
    const size_t lanes = std::min<size_t>(N, rays.count - base);
    for (size_t i = 0; i < N; ++i) {
      const size_t r = base + (i < lanes ? i : 0);
      const bool active = i < lanes && rays.tmax[r] > 0.0f;
      valid[i] = active ? -1 : 0;
      packet.org_x[i] = active ? rays.org[0][r] : 0.0f;
      packet.org_y[i] = active ? rays.org[1][r] : 0.0f;
      packet.org_z[i] = active ? rays.org[2][r] : 0.0f;
      packet.tnear[i] = 0.0f;
      packet.dir_x[i] = active ? rays.dir[0][r] : 0.0f;
      packet.dir_y[i] = active ? rays.dir[1][r] : 0.0f;
      packet.dir_z[i] = active ? rays.dir[2][r] : 1.0f;
      packet.time[i] = 0.0f;
      packet.tfar[i] = active ? rays.tmax[r] : 0.0f;
      packet.mask[i] = 0xffffffffu;
      packet.id[i] = static_cast<unsigned>(i);
      packet.flags[i] = 0;
    }
    rtcOccluded4(valid, scene, &ctx, &packet);
    for (size_t i = 0; i < lanes; ++i)
      occluded[base + i] = valid[i] != 0 && packet.tfar[i] == -std::numeric_limits<float>::infinity() ? 1 : 0;
  }
}

}  // namespace

// Scene layout (every hit goes through exactly one instance level, the only one this Embree build supports):
//   top-level scene (one per frame slot)
//     geomID o < numObjects : instance of animated object o's prototype (object space)
//     geomID numObjects     : instance, identity transform, of the static scene
//   static scene (shared by both slots, built at the first Update)
//     geomID o < numObjects : static object o, baked to world space
//     geomID numObjects     : all emitter triangles, world space, primID = light-triangle index
// Putting static geometry and emitters under one identity instance keeps the per-frame top-level rebuild over a
// few instances only; identity instance transforms are exact in floating point, so static hits are computed
// on the world-space vertices exactly as if the geometry were in the top-level scene.
struct EmbreeScene::Impl {
  struct ObjectRecord {
    bool animated = false;
    int32_t material = 0;
    std::vector<glm::uvec3> triangles;
    std::vector<Vec3> normals;      // object space for animated objects, world space once a static one is baked
    std::vector<Vec2> texcoords;    // per position, only for objects whose material is textured
    std::vector<Vec3> positions;    // object space for animated objects, world space once a static one is baked
    RTCScene prototype = nullptr;   // animated objects only
  };
  struct Slot {
    RTCScene top = nullptr;
    std::vector<RTCGeometry> instances;    // per object; null for static objects
    std::vector<glm::mat3> normalToWorld;  // per object: inverse transpose of objectToWorld (animated only)
    std::vector<glm::dmat4> objectToWorld;  // per object, in double (animated only): for recomputing hits
    std::vector<Mat4> transform;            // per object (animated only): as Embree has it
  };

  RTCDevice device = nullptr;
  RTCScene staticScene = nullptr;
  bool staticHasGeometry = false;
  std::vector<ObjectRecord> objects;
  std::vector<Light> lights;
  std::vector<Vec3> lightNormals;   // per light triangle (zero for a degenerate one)
  std::vector<Vec3> lightVertices;  // per light triangle, its three world-space vertices
  std::vector<int32_t> lightMaterials;  // per light triangle, its light's Light::material (-1: it does not reflect)
  Slot slots[2];
  int current = -1;
  int previous = -1;
  uint32_t staticInstanceId = 0;

  ~Impl() {
    for (auto& s : slots) {
      for (RTCGeometry g : s.instances)
        if (g) rtcReleaseGeometry(g);
      if (s.top) rtcReleaseScene(s.top);
    }
    for (auto& o : objects)
      if (o.prototype) rtcReleaseScene(o.prototype);
    if (staticScene) rtcReleaseScene(staticScene);
    if (device) rtcReleaseDevice(device);
  }

  RTCScene SceneFor(SceneFrame frame) const {
    const int slot = frame == SceneFrame::kCurrent ? current : previous;
    return slot < 0 ? nullptr : slots[slot].top;
  }
  const Slot* SlotFor(SceneFrame frame) const {
    const int slot = frame == SceneFrame::kCurrent ? current : previous;
    return slot < 0 ? nullptr : &slots[slot];
  }

  void BuildStatic(const FrameState& state) {
    staticScene = NewScene(device);
    const uint32_t n = static_cast<uint32_t>(objects.size());
    for (uint32_t o = 0; o < n; ++o) {
      ObjectRecord& rec = objects[o];
      if (rec.animated) continue;
      const Mat4 m = o < state.objectToWorld.size() ? state.objectToWorld[o] : Mat4(1.0f);
      std::vector<Vec3> world(rec.positions.size());
      for (size_t i = 0; i < world.size(); ++i) world[i] = TransformPoint(m, rec.positions[i]);
      const glm::mat3 nm = NormalMatrix(m);
      for (Vec3& nrm : rec.normals) nrm = nm * nrm;
      rec.positions = std::move(world);
      if (rec.triangles.empty()) continue;
      RTCGeometry g = NewTriangleGeometry(device, rec.positions, rec.triangles);
      if (!g) continue;
      rtcAttachGeometryByID(staticScene, g, o);
      rtcReleaseGeometry(g);
      staticHasGeometry = true;
    }
    std::vector<Vec3> lightPositions;
    std::vector<glm::uvec3> lightTris;
    for (const Light& light : lights) {
      for (size_t v = 0; v + 2 < light.vertices.size(); v += 3) {
        const uint32_t base = static_cast<uint32_t>(lightPositions.size());
        lightPositions.push_back(light.vertices[v]);
        lightPositions.push_back(light.vertices[v + 1]);
        lightPositions.push_back(light.vertices[v + 2]);
        lightTris.emplace_back(base, base + 1, base + 2);
      }
    }
    if (!lightTris.empty()) {
      RTCGeometry g = NewTriangleGeometry(device, lightPositions, lightTris);
      if (g) {
        rtcAttachGeometryByID(staticScene, g, n);
        rtcReleaseGeometry(g);
        staticHasGeometry = true;
      }
    }
    CommitSerial(staticScene);
    ThrowOnDeviceError(device, "building the static scene");
  }

  void BuildSlot(Slot& slot) {
    slot.top = NewScene(device);
    const uint32_t n = static_cast<uint32_t>(objects.size());
    slot.instances.assign(n, nullptr);
    slot.normalToWorld.assign(n, glm::mat3(1.0f));
    slot.objectToWorld.assign(n, glm::dmat4(1.0));
    slot.transform.assign(n, Mat4(1.0f));
    for (uint32_t o = 0; o < n; ++o) {
      if (!objects[o].animated || !objects[o].prototype) continue;
      RTCGeometry inst = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(inst, objects[o].prototype);
      rtcSetGeometryTimeStepCount(inst, 1);
      rtcAttachGeometryByID(slot.top, inst, o);
      slot.instances[o] = inst;  // keep our reference: transforms change every frame
    }
    if (staticHasGeometry) {
      RTCGeometry inst = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(inst, staticScene);
      rtcSetGeometryTimeStepCount(inst, 1);
      const Mat4 identity(1.0f);
      rtcSetGeometryTransform(inst, 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, &identity[0][0]);
      rtcCommitGeometry(inst);
      rtcAttachGeometryByID(slot.top, inst, staticInstanceId);
      rtcReleaseGeometry(inst);
    }
  }

  void SetSlot(Slot& slot, const FrameState& state) {
    const uint32_t n = static_cast<uint32_t>(objects.size());
    for (uint32_t o = 0; o < n; ++o) {
      if (!slot.instances[o]) continue;
      const Mat4 m = o < state.objectToWorld.size() ? state.objectToWorld[o] : Mat4(1.0f);
      rtcSetGeometryTransform(slot.instances[o], 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, &m[0][0]);
      rtcCommitGeometry(slot.instances[o]);
      slot.normalToWorld[o] = NormalMatrix(m);
      slot.objectToWorld[o] = glm::dmat4(m);
      slot.transform[o] = m;
    }
    CommitSerial(slot.top);
    ThrowOnDeviceError(device, "committing a frame's top-level scene");
  }

  static RTCRay MakeRay(const Vec3& org, const Vec3& dir, float tmax) {
    RTCRay r;
    r.org_x = org.x;
    r.org_y = org.y;
    r.org_z = org.z;
    r.tnear = 0.0f;
    r.dir_x = dir.x;
    r.dir_y = dir.y;
    r.dir_z = dir.z;
    r.time = 0.0f;
    r.tfar = tmax;
    r.mask = 0xffffffffu;
    r.id = 0;
    r.flags = 0;
    return r;
  }

  RawHit IntersectRaw(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) const;
  // IntersectRaw, unless the benchmarks' ray hook answers the ray (it is told what Embree answered when it does not).
  RawHit IntersectHooked(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) const;
  bool OccludedRaw(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) const;
  void OccludedBatch(OcclusionApi api, const ShadowRay* rays, uint8_t* occluded, size_t count,
                     SceneFrame frame) const;

#ifdef RESTIR_RAY_HOOKS
  const RayHook* hook = nullptr;  // sim/scene/embree_probe.h: the benchmark's observer
#endif
};

EmbreeScene::EmbreeScene(const Sequence& sequence) : impl_(std::make_unique<Impl>()) {
  Impl& im = *impl_;
  const std::string config = DeviceConfig(gEmbreeIsa.load());
  im.device = rtcNewDevice(config.c_str());
  if (!im.device) {
    throw std::runtime_error("cannot create the Embree device (config \"" + config + "\"): error " +
                             std::to_string(static_cast<int>(rtcGetDeviceError(nullptr))));
  }
  const uint32_t n = static_cast<uint32_t>(sequence.objects.size());
  lightObjectId_ = static_cast<int32_t>(n);
  im.staticInstanceId = n;
  im.objects.resize(n);
  for (uint32_t o = 0; o < n; ++o) {
    const Object& obj = sequence.objects[o];
    Impl::ObjectRecord& rec = im.objects[o];
    rec.animated = obj.animated;
    rec.material = static_cast<int32_t>(obj.material);
    rec.triangles = obj.mesh.triangles;
    // Normals only count when there is one per vertex; anything else falls back to flat shading.
    if (!obj.mesh.normals.empty() && obj.mesh.normals.size() == obj.mesh.positions.size())
      rec.normals = obj.mesh.normals;
    if (obj.material < sequence.materials.size() && sequence.materials[obj.material].baseColorTexture >= 0 &&
        obj.mesh.texcoords.size() == obj.mesh.positions.size())
      rec.texcoords = obj.mesh.texcoords;
    // Kept to recompute hits (static ones are baked to world space at the first Update).
    rec.positions = obj.mesh.positions;
    if (obj.animated) {
      if (rec.triangles.empty()) continue;
      rec.prototype = NewScene(im.device);
      RTCGeometry g = NewTriangleGeometry(im.device, obj.mesh.positions, rec.triangles);
      if (g) {
        rtcAttachGeometryByID(rec.prototype, g, 0);
        rtcReleaseGeometry(g);
      }
      CommitSerial(rec.prototype);
    }
  }
  ThrowOnDeviceError(im.device, "building object prototypes");
  im.lights = sequence.lights;
  FrameState allOn;
  lights_ = BuildLightTrianglesFrom(im.lights, allOn.lightOn, &lightGroup_);
  im.lightNormals.reserve(lights_.size());
  for (const LightTriangle& t : lights_) im.lightNormals.push_back(t.normal);
  for (const Light& light : im.lights)
    for (size_t v = 0; v + 2 < light.vertices.size(); v += 3) {
      im.lightVertices.insert(im.lightVertices.end(), light.vertices.begin() + v, light.vertices.begin() + v + 3);
      im.lightMaterials.push_back(light.material);
    }
}

EmbreeScene::~EmbreeScene() = default;

// Not thread-safe against queries: the frame loop calls Update between passes, never while one is tracing.
void EmbreeScene::Update(const FrameState& state) {
  Impl& im = *impl_;
  if (im.current < 0) {
    im.BuildStatic(state);
    im.BuildSlot(im.slots[0]);
    im.BuildSlot(im.slots[1]);
    im.SetSlot(im.slots[0], state);
    // Before a second frame exists, "previous" is defined to be the current frame.
    im.current = 0;
    im.previous = 0;
  } else {
    im.previous = im.current;
    im.current ^= 1;
    im.SetSlot(im.slots[im.current], state);
  }
  lights_ = BuildLightTrianglesFrom(im.lights, state.lightOn, &lightGroup_);
}

RawHit EmbreeScene::Impl::IntersectRaw(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) const {
  RawHit out;
  const Slot* slot = SlotFor(frame);
  if (!slot || !(tmax > 0.0f)) return out;
  RTCRayHit rh;
  rh.ray = MakeRay(org, dir, tmax);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  for (unsigned l = 0; l < RTC_MAX_INSTANCE_LEVEL_COUNT; ++l) rh.hit.instID[l] = RTC_INVALID_GEOMETRY_ID;
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  rtcIntersect1(slot->top, &ctx, &rh);
  out.t = rh.ray.tfar;
  out.ngX = rh.hit.Ng_x;
  out.ngY = rh.hit.Ng_y;
  out.ngZ = rh.hit.Ng_z;
  out.u = rh.hit.u;
  out.v = rh.hit.v;
  out.geomId = rh.hit.geomID;
  out.primId = rh.hit.primID;
  out.instId = rh.hit.instID[0];
  return out;
}

RawHit EmbreeScene::Impl::IntersectHooked(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) const {
#ifdef RESTIR_RAY_HOOKS
  RawHit rh;
  if (hook != nullptr && hook->AnswerIntersect(org, dir, tmax, frame, rh)) return rh;
  rh = IntersectRaw(org, dir, tmax, frame);
  if (hook) hook->TracedIntersect(org, dir, tmax, frame, rh);
  return rh;
#else
  return IntersectRaw(org, dir, tmax, frame);
#endif
}

SurfaceHit EmbreeScene::Intersect(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) const {
  return Query(org, dir, tmax, frame, true);
}

EmitterHit EmbreeScene::FirstEmitter(const Vec3& org, const Vec3& dir, SceneFrame frame) const {
  EmitterHit out;
  const Impl& im = *impl_;
  if (!im.SlotFor(frame)) return out;
  const float tmax = std::numeric_limits<float>::infinity();
  const RawHit rh = im.IntersectHooked(org, dir, tmax, frame);
  if (rh.geomId == RTC_INVALID_GEOMETRY_ID) return out;
  const uint32_t objectOrLights = rh.instId == im.staticInstanceId ? rh.geomId : rh.instId;
  if (objectOrLights < static_cast<uint32_t>(im.objects.size()) || rh.primId >= im.lightNormals.size()) return out;
  out.lightId = static_cast<int32_t>(rh.primId);
  // Embree's t divides by an approximate reciprocal (rcpps plus a Newton step), whose last bits differ between
  // CPU vendors; the reference weighs this hit by t², so t is recomputed from the triangle in double to keep its
  // bits one answer on every machine. A ray parallel to the plane keeps Embree's t.
  double t = rh.t;
  if (3 * size_t(rh.primId) + 2 < im.lightVertices.size()) {
    glm::dvec3 p[3];
    for (int k = 0; k < 3; ++k) p[k] = glm::dvec3(im.lightVertices[3 * size_t(rh.primId) + k]);
    double planeT = 0.0, u = 0.0, v = 0.0;
    if (IntersectPlane(glm::dvec3(org), glm::dvec3(dir), p[0], p[1], p[2], planeT, u, v)) t = planeT;
  }
  out.t = static_cast<float>(t);
  out.frontFace = glm::dot(dir, im.lightNormals[rh.primId]) < 0.0f;
  return out;
}

SurfaceHit EmbreeScene::IntersectEmitter(const Vec3& org, const Vec3& dir, float tmax,
                                         SceneFrame frame) const {
  return Query(org, dir, tmax, frame, false);
}

SurfaceHit EmbreeScene::Query(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame,
                              bool surface) const {
  SurfaceHit out;
  const Impl& im = *impl_;
  const Impl::Slot* slot = im.SlotFor(frame);
  if (!slot || !(tmax > 0.0f)) return out;

  const RawHit rh = im.IntersectHooked(org, dir, tmax, frame);
  if (rh.geomId == RTC_INVALID_GEOMETRY_ID) return out;

  const uint32_t inst = rh.instId;
  const uint32_t n = static_cast<uint32_t>(im.objects.size());
  const bool isStatic = inst == im.staticInstanceId;
  const uint32_t objectOrLights = isStatic ? rh.geomId : inst;
  const bool emitter = objectOrLights >= n;
  const uint32_t prim = rh.primId;

  // The hit triangle's world-space vertices, in double, and the error scale they give points on it.
  glm::dvec3 p[3];
  float errorScale = 0.0f;
  const Impl::ObjectRecord* rec = emitter ? nullptr : &im.objects[objectOrLights];
  if (emitter) {
    if (3 * size_t(prim) + 2 >= im.lightVertices.size()) return out;
    for (int k = 0; k < 3; ++k) p[k] = glm::dvec3(im.lightVertices[3 * size_t(prim) + k]);
  } else {
    if (prim >= rec->triangles.size()) return out;
    if (!surface) {
      out.hit = true;
      out.objectId = static_cast<int32_t>(objectOrLights);
      out.materialId = rec->material;
      return out;
    }
    const glm::uvec3 tri = rec->triangles[prim];
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3 v(rec->positions[tri[k]]);
      p[k] = isStatic ? v : glm::dvec3(slot->objectToWorld[objectOrLights] * glm::dvec4(v, 1.0));
    }
  }
  for (const glm::dvec3& q : p) errorScale = std::max(errorScale, MaxAbs(q));
  if (!emitter && !isStatic) errorScale = InstanceErrorScale(slot->transform[objectOrLights], errorScale);

  const glm::dvec3 o(org), d(dir);
  double t = rh.t, u = rh.u, v = rh.v;
  // A ray exactly parallel to the plane can still graze an edge in Embree's watertight test; it keeps Embree's
  // answer.
  IntersectPlane(o, d, p[0], p[1], p[2], t, u, v);
  const glm::dvec3 position = (1.0 - u - v) * p[0] + u * p[1] + v * p[2];
  out.hit = true;
  out.t = static_cast<float>(t);
  out.position = Vec3(position);
  out.errorScale = errorScale;

  glm::dvec3 ngd = glm::cross(p[1] - p[0], p[2] - p[0]);
  const double ngLength = glm::length(ngd);
  Vec3 ng = ngLength > 0.0 && std::isfinite(ngLength) ? Vec3(ngd / ngLength) : glm::normalize(Vec3(rh.ngX, rh.ngY, rh.ngZ));
  if (glm::dot(ng, dir) > 0.0f) ng = -ng;
  out.geometricNormal = ng;
  out.shadingNormal = ng;

  if (emitter) {
    out.objectId = lightObjectId_;
    // A reflecting emitter is a flat-shaded, untextured surface too (the reader refuses a textured material on a
    // light).
    out.materialId = prim < im.lightMaterials.size() ? im.lightMaterials[prim] : -1;
    out.lightId = static_cast<int32_t>(prim);
    const Vec3 ln = prim < im.lightNormals.size() ? im.lightNormals[prim] : Vec3(0.0f);
    out.frontFace = glm::dot(dir, ln) < 0.0f;
    return out;
  }

  out.objectId = static_cast<int32_t>(objectOrLights);
  out.materialId = rec->material;
  out.lightId = -1;
  out.frontFace = true;
  if (!rec->texcoords.empty()) {
    const glm::uvec3 tri = rec->triangles[prim];
    const glm::dvec2 uv = (1.0 - u - v) * glm::dvec2(rec->texcoords[tri.x]) + u * glm::dvec2(rec->texcoords[tri.y]) +
                          v * glm::dvec2(rec->texcoords[tri.z]);
    out.texcoord = Vec2(uv);
  }
  if (!rec->normals.empty()) {
    const glm::uvec3 tri = rec->triangles[prim];
    const glm::dvec3 nd = (1.0 - u - v) * glm::dvec3(rec->normals[tri.x]) + u * glm::dvec3(rec->normals[tri.y]) +
                          v * glm::dvec3(rec->normals[tri.z]);
    Vec3 ns(nd);
    if (!isStatic) ns = slot->normalToWorld[objectOrLights] * ns;
    const float len = glm::length(ns);
    if (len > 0.0f && std::isfinite(len)) {
      ns /= len;
      // Two-sided shading: the shading normal lives on the side of the surface the ray sees.
      out.shadingNormal = glm::dot(ns, ng) < 0.0f ? -ns : ns;
    }
  }
  return out;
}

bool EmbreeScene::Occluded(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) const {
#ifdef RESTIR_RAY_HOOKS
  if (const RayHook* hook = impl_->hook) {
    bool occluded = false;
    if (hook->AnswerOccluded(org, dir, tmax, frame, occluded)) return occluded;
    occluded = impl_->OccludedRaw(org, dir, tmax, frame);
    hook->TracedOccluded(org, dir, tmax, frame, occluded);
    return occluded;
  }
#endif
  return impl_->OccludedRaw(org, dir, tmax, frame);
}

bool EmbreeScene::Impl::OccludedRaw(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) const {
  RTCScene scene = SceneFor(frame);
  if (!scene || !(tmax > 0.0f)) return false;
  RTCRay ray = MakeRay(org, dir, tmax);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  rtcOccluded1(scene, &ctx, &ray);
  // Embree marks a blocked ray by setting tfar to -inf.
  return ray.tfar == -std::numeric_limits<float>::infinity();
}


void EmbreeScene::OccludedBatch(const ShadowRay* rays, uint8_t* occluded, size_t count, SceneFrame frame) const {
#ifdef RESTIR_RAY_HOOKS
  if (impl_->hook != nullptr) {  // recorded or answered ray by ray
    for (size_t i = 0; i < count; ++i) occluded[i] = Occluded(rays[i].org, rays[i].dir, rays[i].tmax, frame) ? 1 : 0;
    return;
  }
#endif
  impl_->OccludedBatch(OcclusionApi::k4, rays, occluded, count, frame);
}

void EmbreeScene::OccludedBatch(const ShadowRaysSoa& rays, uint8_t* occluded, SceneFrame frame) const {
#ifdef RESTIR_RAY_HOOKS
  if (impl_->hook != nullptr) {  // recorded or answered ray by ray
    for (size_t i = 0; i < rays.count; ++i)
      occluded[i] = Occluded(Vec3(rays.org[0][i], rays.org[1][i], rays.org[2][i]),
                             Vec3(rays.dir[0][i], rays.dir[1][i], rays.dir[2][i]), rays.tmax[i], frame)
                        ? 1
                        : 0;
    return;
  }
#endif
  RTCScene scene = impl_->SceneFor(frame);
  if (!scene) {
    std::fill(occluded, occluded + rays.count, uint8_t{0});
    return;
  }
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;  // as the AoS batch: the same traversal, the same answers
  OccludedPacketsSoa(scene, ctx, rays, occluded);
}

void EmbreeScene::Impl::OccludedBatch(OcclusionApi api, const ShadowRay* rays, uint8_t* occluded, size_t count,
                                      SceneFrame frame) const {
  RTCScene scene = SceneFor(frame);
  if (!scene) {
    std::fill(occluded, occluded + count, uint8_t{0});
    return;
  }
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  // Shadow rays of one pass are incoherent (different pixels, different lights).
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  switch (api) {
    case OcclusionApi::k1:
      for (size_t i = 0; i < count; ++i)
        occluded[i] = OccludedRaw(rays[i].org, rays[i].dir, rays[i].tmax, frame) ? 1 : 0;
      return;
    case OcclusionApi::k4:
      OccludedPackets<4, RTCRay4>(scene, ctx, rays, occluded, count,
                                  [](const int* v, RTCScene s, RTCIntersectContext* c, RTCRay4* p) {
                                    rtcOccluded4(v, s, c, p);
                                  });
      return;
    case OcclusionApi::k8:
      OccludedPackets<8, RTCRay8>(scene, ctx, rays, occluded, count,
                                  [](const int* v, RTCScene s, RTCIntersectContext* c, RTCRay8* p) {
                                    rtcOccluded8(v, s, c, p);
                                  });
      return;
    case OcclusionApi::k16:
      OccludedPackets<16, RTCRay16>(scene, ctx, rays, occluded, count,
                                    [](const int* v, RTCScene s, RTCIntersectContext* c, RTCRay16* p) {
                                      rtcOccluded16(v, s, c, p);
                                    });
      return;
    case OcclusionApi::kStream1M: {
      // In chunks, so the RTCRay copies stay in cache. An inactive ray (tmax <= 0) gets tnear > tfar, which
      // Embree skips, so it keeps its tfar and reads as unoccluded.
      constexpr size_t kChunk = 256;
      alignas(64) RTCRay chunk[kChunk];
      for (size_t base = 0; base < count; base += kChunk) {
        const size_t m = std::min(kChunk, count - base);
        for (size_t i = 0; i < m; ++i) {
          const ShadowRay& r = rays[base + i];
          const bool active = r.tmax > 0.0f;
          chunk[i] = MakeRay(r.org, active ? r.dir : Vec3(0.0f, 0.0f, 1.0f), active ? r.tmax : 0.0f);
          if (!active) chunk[i].tnear = 1.0f;
        }
        rtcOccluded1M(scene, &ctx, chunk, static_cast<unsigned>(m), sizeof(RTCRay));
        for (size_t i = 0; i < m; ++i)
          occluded[base + i] = chunk[i].tfar == -std::numeric_limits<float>::infinity() ? 1 : 0;
      }
      return;
    }
  }
}

std::vector<LightTriangle> BuildLightTriangles(const Sequence& sequence, const FrameState& state,
                                               std::vector<uint32_t>* groupOf) {
  return BuildLightTrianglesFrom(sequence.lights, state.lightOn, groupOf);
}

const char* EmbreeIsaName(EmbreeIsa isa) {
  switch (isa) {
    case EmbreeIsa::kSse42: return "sse4.2";
    case EmbreeIsa::kAvx2: return "avx2";
    case EmbreeIsa::kAvx512: return "avx512";
  }
  return "sse4.2";
}

std::optional<EmbreeIsa> ParseEmbreeIsa(const std::string& name) {
  for (EmbreeIsa isa : {EmbreeIsa::kSse42, EmbreeIsa::kAvx2, EmbreeIsa::kAvx512})
    if (name == EmbreeIsaName(isa)) return isa;
  return std::nullopt;
}

namespace {

bool EmbreeIsaSupported(EmbreeIsa isa) {
  // Embree silently falls back to a lesser ISA when the CPU lacks the one asked for, so ask the CPU.
  __builtin_cpu_init();
  const bool supported = isa == EmbreeIsa::kSse42   ? __builtin_cpu_supports("sse4.2")
                         : isa == EmbreeIsa::kAvx2 ? __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")
                                                   : __builtin_cpu_supports("avx512f") &&
                                                         __builtin_cpu_supports("avx512vl") &&
                                                         __builtin_cpu_supports("avx512bw") &&
                                                         __builtin_cpu_supports("avx512dq");
  if (!supported) return false;
  RTCDevice device = rtcNewDevice(DeviceConfig(isa).c_str());
  if (!device) return false;
  rtcReleaseDevice(device);
  return true;
}

}  // namespace

bool SetEmbreeIsa(EmbreeIsa isa) {
  if (!EmbreeIsaSupported(isa)) return false;
  gEmbreeIsa.store(isa);
  return true;
}

EmbreeIsa BestEmbreeIsa() {
  for (EmbreeIsa isa : {EmbreeIsa::kAvx512, EmbreeIsa::kAvx2})
    if (EmbreeIsaSupported(isa)) return isa;
  return EmbreeIsa::kSse42;
}

EmbreeIsa ActiveEmbreeIsa() { return gEmbreeIsa.load(); }

#ifdef RESTIR_RAY_HOOKS

struct EmbreeProbe {
  static EmbreeScene::Impl& Of(const EmbreeScene& scene) { return *scene.impl_; }
};

void SetRayHook(EmbreeScene& scene, const RayHook* hook) { EmbreeProbe::Of(scene).hook = hook; }

RawHit IntersectRaw(const EmbreeScene& scene, const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) {
  return EmbreeProbe::Of(scene).IntersectRaw(org, dir, tmax, frame);
}

bool OccludedRaw(const EmbreeScene& scene, const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) {
  return EmbreeProbe::Of(scene).OccludedRaw(org, dir, tmax, frame);
}

void OccludedBatch(const EmbreeScene& scene, OcclusionApi api, const ShadowRay* rays, uint8_t* occluded,
                   size_t count, SceneFrame frame) {
  if (EmbreeProbe::Of(scene).hook != nullptr) {
    scene.OccludedBatch(rays, occluded, count, frame);
    return;
  }
  EmbreeProbe::Of(scene).OccludedBatch(api, rays, occluded, count, frame);
}

#endif  // RESTIR_RAY_HOOKS

}  // namespace restir
