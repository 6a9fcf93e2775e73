#include "sim/scene/animation.h"

#include <algorithm>
#include <cmath>

namespace restir {

namespace {

// Exact values at multiples of 90 degrees, so a quarter turn maps axes onto axes without 1e-8 residue.
void SinCosDegrees(float degrees, float& s, float& c) {
  const float quarter = degrees / 90.0f;
  if (quarter == std::floor(quarter) && std::fabs(quarter) < 1e6f) {
    static constexpr float kSin[4] = {0.0f, 1.0f, 0.0f, -1.0f};
    static constexpr float kCos[4] = {1.0f, 0.0f, -1.0f, 0.0f};
    const int q = ((static_cast<int>(quarter) % 4) + 4) % 4;
    s = kSin[q];
    c = kCos[q];
    return;
  }
  const float r = glm::radians(degrees);
  s = std::sin(r);
  c = std::cos(r);
}

}  // namespace

Mat4 TransformMatrix(const Vec3& translate, const Vec3& rotateDegrees, const Vec3& scale) {
  float sx, cx, sy, cy, sz, cz;
  SinCosDegrees(rotateDegrees.x, sx, cx);
  SinCosDegrees(rotateDegrees.y, sy, cy);
  SinCosDegrees(rotateDegrees.z, sz, cz);
  // GLM matrices are column-major: m[column][row].
  Mat4 rx(1.0f), ry(1.0f), rz(1.0f), s(1.0f), t(1.0f);
  rx[1][1] = cx;
  rx[1][2] = sx;
  rx[2][1] = -sx;
  rx[2][2] = cx;
  ry[0][0] = cy;
  ry[0][2] = -sy;
  ry[2][0] = sy;
  ry[2][2] = cy;
  rz[0][0] = cz;
  rz[0][1] = sz;
  rz[1][0] = -sz;
  rz[1][1] = cz;
  s[0][0] = scale.x;
  s[1][1] = scale.y;
  s[2][2] = scale.z;
  t[3] = Vec4(translate, 1.0f);
  return t * rz * ry * rx * s;
}

namespace {

// Finds the segment containing frame and the (eased) parameter within it; clamps outside the keyed range.
template <typename Key>
void FindSegment(const std::vector<Key>& keys, int frame, size_t& i, float& t) {
  i = 0;
  t = 0.0f;
  if (keys.size() < 2 || frame <= keys.front().frame) return;
  if (frame >= keys.back().frame) {
    i = keys.size() - 1;
    return;
  }
  // The last key at or before the frame (keys are sorted, frames distinct): a binary search, since a sequence may
  // hold 100000 keys and validate evaluates every frame.
  i = static_cast<size_t>(std::upper_bound(keys.begin(), keys.end(), frame,
                                           [](int f, const Key& k) { return f < k.frame; }) -
                          keys.begin()) -
      1;
  t = static_cast<float>(frame - keys[i].frame) / static_cast<float>(keys[i + 1].frame - keys[i].frame);
  if (keys[i].interpolation == Interpolation::kSmooth) t = t * t * (3.0f - 2.0f * t);  // smoothstep
}

// The key in effect at `frame`: a key itself, or a copy of its segment's first key at `frame` whose interpolated
// fields `blend(k, a, b, t)` fills from the segment's keys a and b.
template <typename Key, typename Blend>
Key InterpolateKeys(const std::vector<Key>& keys, int frame, Blend blend) {
  size_t i;
  float t;
  FindSegment(keys, frame, i, t);
  if (t == 0.0f) return keys[i];
  Key k = keys[i];
  k.frame = frame;
  blend(k, keys[i], keys[i + 1], t);
  return k;
}

}  // namespace

CameraKey InterpolateCamera(const std::vector<CameraKey>& keys, int frame) {
  return InterpolateKeys(keys, frame, [](CameraKey& k, const CameraKey& a, const CameraKey& b, float t) {
    k.position = glm::mix(a.position, b.position, t);
    k.lookAt = glm::mix(a.lookAt, b.lookAt, t);
    k.vfovDegrees = glm::mix(a.vfovDegrees, b.vfovDegrees, t);
  });
}

TransformKey InterpolateTransform(const std::vector<TransformKey>& keys, int frame) {
  return InterpolateKeys(keys, frame, [](TransformKey& k, const TransformKey& a, const TransformKey& b, float t) {
    k.translate = glm::mix(a.translate, b.translate, t);
    k.rotateDegrees = glm::mix(a.rotateDegrees, b.rotateDegrees, t);
    k.scale = glm::mix(a.scale, b.scale, t);
  });
}

EnvironmentKey InterpolateEnvironment(const std::vector<EnvironmentKey>& keys, int frame) {
  return InterpolateKeys(keys, frame, [](EnvironmentKey& k, const EnvironmentKey& a, const EnvironmentKey& b, float t) {
    k.intensity = glm::mix(a.intensity, b.intensity, t);
    k.rotationDegrees = glm::mix(a.rotationDegrees, b.rotationDegrees, t);
  });
}

SunKey InterpolateSun(const std::vector<SunKey>& keys, int frame) {
  return InterpolateKeys(keys, frame, [](SunKey& k, const SunKey& a, const SunKey& b, float t) {
    k.intensity = glm::mix(a.intensity, b.intensity, t);
    const Vec3 d = glm::mix(a.direction, b.direction, t);
    const float length = glm::length(d);
    if (length > kMinSunLerp) k.direction = d / length;
  });
}

bool IsOn(const std::vector<std::pair<int, int>>& onRanges, int frame) {
  bool on = onRanges.empty();
  for (const auto& [first, last] : onRanges) on = on || (frame >= first && frame < last);
  return on;
}

Camera MakeCamera(const CameraKey& key, int width, int height) {
  Camera cam;
  cam.position = key.position;
  cam.vfovDegrees = key.vfovDegrees;
  cam.width = width;
  cam.height = height;
  const Vec3 d = key.lookAt - key.position;
  const float len = glm::length(d);
  cam.forward = len > kMinLookDistance ? d / len : Vec3(0.0f, 0.0f, -1.0f);
  Vec3 side = glm::cross(cam.forward, Vec3(0.0f, 1.0f, 0.0f));
  if (glm::length(side) < 1e-6f) {
    // Looking straight up or down: take image-up along -z / +z so that right stays +x.
    side = glm::cross(cam.forward, Vec3(0.0f, 0.0f, cam.forward.y > 0.0f ? 1.0f : -1.0f));
  }
  cam.right = glm::normalize(side);
  cam.up = glm::cross(cam.right, cam.forward);
  return cam;
}

FrameState Evaluate(const Sequence& sequence, int frame, int width, int height) {
  FrameState state;
  state.frame = frame;
  if (!sequence.cameraKeys.empty()) {
    state.camera = MakeCamera(InterpolateCamera(sequence.cameraKeys, frame), width, height);
  } else {
    state.camera.width = width;
    state.camera.height = height;
  }
  state.objectToWorld.reserve(sequence.objects.size());
  for (const Object& obj : sequence.objects) {
    if (obj.keys.empty()) {
      state.objectToWorld.push_back(Mat4(1.0f));
      continue;
    }
    const TransformKey k = InterpolateTransform(obj.keys, frame);
    state.objectToWorld.push_back(TransformMatrix(k.translate, k.rotateDegrees, k.scale));
  }
  state.lightOn.reserve(sequence.lights.size());
  for (const Light& light : sequence.lights) state.lightOn.push_back(IsOn(light.onRanges, frame) ? 1 : 0);
  const Environment& environment = sequence.environment;
  if (environment.present && !environment.keys.empty()) {
    const EnvironmentKey k = InterpolateEnvironment(environment.keys, frame);
    state.environmentIntensity = IsOn(environment.onRanges, frame) ? k.intensity : 0.0f;
    state.environmentRotationDegrees = k.rotationDegrees;
  }
  const Sun& sun = sequence.sun;
  if (sun.present && !sun.keys.empty()) {
    const SunKey k = InterpolateSun(sun.keys, frame);
    state.sunIntensity = IsOn(sun.onRanges, frame) ? k.intensity : 0.0f;
    state.sunDirection = k.direction;
  }
  return state;
}

}  // namespace restir
