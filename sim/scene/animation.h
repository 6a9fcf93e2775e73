// The animation of a sequence (DESIGN §2 state_t = Evaluate(sequence, t)): keyframe interpolation, object
// transforms and the camera basis. Evaluate itself is declared in sim/scene/sequence.h.
#pragma once

#include <utility>
#include <vector>

#include "sim/scene/sequence.h"

namespace restir {

// The camera's view distance below which position and lookAt count as the same point.
inline constexpr float kMinLookDistance = 1e-6f;

// world = T(translate) * Rz * Ry * Rx (degrees) * S(scale); exact at multiples of 90 degrees.
Mat4 TransformMatrix(const Vec3& translate, const Vec3& rotateDegrees, const Vec3& scale);

// The keys at `frame`: linear or smoothstep between the keys around it, clamped outside the keyed range.
CameraKey InterpolateCamera(const std::vector<CameraKey>& keys, int frame);
TransformKey InterpolateTransform(const std::vector<TransformKey>& keys, int frame);
// Intensity and rotation each interpolated as a number.
EnvironmentKey InterpolateEnvironment(const std::vector<EnvironmentKey>& keys, int frame);
// Intensity as a number; the direction as normalize(lerp) of the two keys' directions, or the earlier key's where
// the lerp is shorter than kMinSunLerp (opposite keys half-way), which has no direction to normalise.
SunKey InterpolateSun(const std::vector<SunKey>& keys, int frame);
inline constexpr float kMinSunLerp = 1e-6f;

// Whether a light, the environment or the sun with these [first, last) ranges is on at `frame` (empty: always).
bool IsOn(const std::vector<std::pair<int, int>>& onRanges, int frame);

// The camera of a key: forward towards lookAt, right = forward x +Y (or x +-Z looking straight up or down).
Camera MakeCamera(const CameraKey& key, int width, int height);

}  // namespace restir
