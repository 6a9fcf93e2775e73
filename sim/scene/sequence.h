// A scripted sequence: the scene (materials, objects, lights), its animation (camera and object keyframes,
// light on/off intervals) and default render settings, as read from a JSON file (DESIGN §8).
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/math.h"
#include "core/sky.h"
#include "sim/assets/texture.h"
#include "sim/util/input_error.h"  // InputError, for the readers' callers

namespace restir {

// kLayered is the metallic-roughness material of imported assets (glTF, MTL), mapped to core/'s layered BSDF
// by MaterialBsdf (sim/scene/shading_point.h; docs/sequence-format.md "Material mapping").
enum class MaterialType { kDiffuse, kGgx, kLayered };

struct Material {
  std::string name;                     // unique name, referenced by objects
  MaterialType type = MaterialType::kDiffuse;
  Vec3 albedo{0.8f};                    // diffuse reflectance, the GGX Fresnel F0 colour, or kLayered's base colour
  float roughness = 0.5f;               // GGX alpha = roughness^2 (kGgx and kLayered)
  float metallic = 0.0f;                // kLayered: glTF metallic factor in [0, 1]
  float specular = 0.04f;               // kLayered: dielectric reflectance at normal incidence in [0, 1]
  int32_t baseColorTexture = -1;        // index into Sequence::textures multiplying albedo at the hit; -1: none
};

// Triangle mesh in object space. Normals are optional per-vertex shading normals (empty: flat shading).
// Every number a sequence or its meshes give (coordinates, sizes, angles, scales, colours, intensities) is at most
// this in magnitude, so products of a few of them stay finite in single precision (sequence.cpp has the argument).
inline constexpr double kMaxSequenceNumber = 1e7;

struct Mesh {
  std::vector<Vec3> positions;
  std::vector<glm::uvec3> triangles;
  std::vector<Vec3> normals;
  std::vector<Vec2> texcoords;  // per position (v up), or empty; only textured materials read them
};

enum class Interpolation { kLinear, kSmooth };

// Object transform keyframe: world = T(translate) * R(rotate, degrees, applied X then Y then Z) * S(scale).
struct TransformKey {
  int frame = 0;
  Vec3 translate{0.0f};
  Vec3 rotateDegrees{0.0f};
  Vec3 scale{1.0f};
  Interpolation interpolation = Interpolation::kLinear;  // how to move from this key to the next
};

struct Object {
  std::string name;                 // unique
  uint32_t material = 0;            // index into Sequence::materials
  Mesh mesh;                        // object space, already generated (quad, box, sphere, bars, OBJ)
  std::vector<TransformKey> keys;   // sorted by frame; at least one (identity when the file gives none)
  bool animated = false;            // true when the keys differ, so the transform changes over time
};

// A named group of emissive triangles (a quad light is two; a grid generator gives many groups).
struct Light {
  std::string name;                           // unique
  std::vector<Vec3> vertices;                 // world space, 3 per triangle, counter-clockwise seen from the lit side
  Vec3 radiance{1.0f};                        // colour * intensity
  // Per triangle when they differ (an imported mesh's emission times its texture's mean over each triangle);
  // empty: `radiance` for every triangle.
  std::vector<Vec3> triangleRadiance;
  std::vector<std::pair<int, int>> onRanges;  // frames [first, last) during which it is on; empty: always on
  // Index into Sequence::materials of the surface the emitter also is (it reflects light by that material, on
  // both sides, as any surface; its emission stays one-sided), or -1: it only emits (docs/sequence-format.md).
  int32_t material = -1;
};

// The light at infinity (docs/sequence-format.md "Sky"; DESIGN §8): an environment and a sun, each animated by
// keyframes and switched on and off like the lights.
struct EnvironmentKey {
  int frame = 0;
  float intensity = 1.0f;        // multiplies the map's (or the colour's) radiance
  float rotationDegrees = 0.0f;  // rotation of the map about +Y (counter-clockwise seen from above)
  Interpolation interpolation = Interpolation::kLinear;
};

struct Environment {
  bool present = false;
  EnvironmentMap map;                          // linear RGB radiance (core/sky.h); a constant sky is 1x1
  std::string file;                            // the map's file as the sequence names it, or empty for a colour
  std::vector<EnvironmentKey> keys;            // sorted by frame; at least one when present
  std::vector<std::pair<int, int>> onRanges;   // frames [first, last) during which it is on; empty: always on
  // The importance sampler of `map`, built once (sim/scene/sky_frame.h PrepareEnvironment) and shared by every frame.
  std::shared_ptr<const EnvironmentSampler> sampler;
};

struct SunKey {
  int frame = 0;
  Vec3 direction{0.0f, 1.0f, 0.0f};  // unit, from the scene towards the sun
  float intensity = 1.0f;            // multiplies Sun::radiance
  Interpolation interpolation = Interpolation::kLinear;
};

struct Sun {
  bool present = false;
  Vec3 radiance{0.0f};                       // inside the disc (given, or from the illuminance at normal incidence)
  float angularDiameterDegrees = 0.53f;      // the disc's apparent diameter
  std::vector<SunKey> keys;                  // sorted by frame; at least one when present
  std::vector<std::pair<int, int>> onRanges; // frames [first, last) during which it is on; empty: always on
};

struct CameraKey {
  int frame = 0;
  Vec3 position{0.0f};
  Vec3 lookAt{0.0f, 0.0f, -1.0f};
  float vfovDegrees = 45.0f;
  Interpolation interpolation = Interpolation::kLinear;  // how to move from this key to the next
};

struct RenderDefaults {
  std::vector<std::string> presets{"ris"};  // presets a plain `restir-sim run FILE` replays
  int referenceSpp = 1024;                  // reference samples per pixel (when referenceError is 0)
  // The relative standard error each pixel's reference is sampled to (sim/reference/reference.h
  // ReferenceParams::targetRelativeError); 0: a fixed budget of referenceSpp instead.
  double referenceError = 0.0;
  // With referenceError: the most samples a frame's reference may take, as a mean per pixel (0: no cap). Hitting
  // it is reported per frame (metrics.csv reference_capped), never silent.
  int referenceSppCap = 0;
};

struct Sequence {
  std::string path;          // the file it was read from
  std::string name;
  std::string description;
  int width = 640;
  int height = 360;
  int frameCount = 1;
  float frameRate = 30.0f;
  uint32_t seed = 1;
  std::vector<Material> materials;
  std::vector<Texture> textures;     // base-colour textures of imported assets, referenced by materials
  std::vector<Object> objects;
  std::vector<Light> lights;
  Environment environment;           // the sky's environment, if any
  Sun sun;                           // the sun, if any
  std::vector<CameraKey> cameraKeys;  // sorted by frame; at least one
  RenderDefaults defaults;
  std::string contentHash;  // hex hash of the file's bytes and of every mesh file it loads
  // What importing assets left out, for `validate` (docs/sequence-format.md "What is ignored"): counted, not errors.
  uint64_t skippedPrimitives = 0;        // points and lines in assets
  uint64_t skippedZeroAreaEmitters = 0;  // emissive triangles with no area, which cannot emit
  uint64_t skippedDarkEmitters = 0;      // emissive triangles whose radiance averages to zero over their texture
};

// Pinhole camera at one frame. Up is +Y.
struct Camera {
  Vec3 position{0.0f};
  Vec3 forward{0.0f, 0.0f, -1.0f};  // unit
  Vec3 right{1.0f, 0.0f, 0.0f};     // unit
  Vec3 up{0.0f, 1.0f, 0.0f};        // unit
  float vfovDegrees = 45.0f;
  int width = 1;
  int height = 1;

  // Primary ray direction (unit) through continuous pixel coordinates (px, py); pixel centres are at +0.5,
  // y grows downwards in the image.
  Vec3 RayDirection(float px, float py) const;
  // Inverse of RayDirection: continuous pixel coordinates of a world point; false when behind the camera.
  bool Project(const Vec3& world, float& px, float& py) const;
  // Distance along the forward axis (view depth).
  float ViewDepth(const Vec3& world) const { return glm::dot(world - position, forward); }
};

// Everything that changes per frame (DESIGN §2 state_t).
struct FrameState {
  int frame = 0;
  Camera camera;
  std::vector<Mat4> objectToWorld;  // one per Sequence::objects
  std::vector<uint8_t> lightOn;     // one per Sequence::lights
  // The sky at this frame (zero radiance where the sequence has none or it is switched off).
  float environmentIntensity = 0.0f;   // 0 when off or absent
  float environmentRotationDegrees = 0.0f;
  Vec3 sunDirection{0.0f, 1.0f, 0.0f};  // unit
  float sunIntensity = 0.0f;            // multiplies Sun::radiance; 0 when off or absent
};

// Reads and validates a sequence file. Throws InputError with file:line:column and JSON path on any problem
// (syntax, wrong type, unknown key with a suggestion, out-of-range value, missing mesh, zero-area light ...).
Sequence LoadSequence(const std::string& path);
// Same, from text (path only names it in messages; relative mesh paths resolve against baseDir).
Sequence ParseSequence(const std::string& text, const std::string& path, const std::string& baseDir);

// Camera, transforms and light states at a frame (clamped to the first/last key outside the keyed range).
FrameState Evaluate(const Sequence& sequence, int frame, int width, int height);

// One-screen summary for `restir-sim validate`: objects, lights, emitter triangles, frames, camera path length.
std::string SummarizeSequence(const Sequence& sequence);

}  // namespace restir
