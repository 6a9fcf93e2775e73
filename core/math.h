// Small math vocabulary shared by core/ and sim/. GLM supplies the vector types; everything here is plain
// IEEE single precision so that scalar and SIMD code agree bit for bit (DESIGN §3).
#pragma once

#include <glm/glm.hpp>

#include <cmath>
#include <cstdint>
#include <limits>

namespace restir {

using Vec2 = glm::vec2;
using Vec3 = glm::vec3;
using Vec4 = glm::vec4;
using Mat4 = glm::mat4;

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInvPi = 0.31830988618379067154f;
// The largest float below 1 (pbrt-v4's OneMinusEpsilon): where a rescaled uniform is clamped so it stays in [0, 1).
inline constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

// Rec. 709 luminance (DESIGN §4 target and §6 metrics; ITU-R BT.709-6 item 3.2), in float for the estimator and in
// double where the reference's replicates and FLIP's exposure range accumulate it (core/shading-inl.h has the SIMD
// twin of the float one).
inline float Luminance(const Vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
inline double Luminance(const glm::dvec3& c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

// A NaN result's sign and payload are not a property of the inputs: when a NaN input meets a NaN an operation
// creates (x86's default NaN is negative), the result is whichever operand the compiler placed first, and the
// compiler may commute an add or a multiply differently in each compilation. So every NaN a SIMD kernel or its
// scalar twin writes is this one (core/kernel-inl.h CanonicalNaNV per lane), on every target.
inline float CanonicalNaN(float v) { return std::isnan(v) ? std::numeric_limits<float>::quiet_NaN() : v; }

inline bool IsFinite(float v) { return std::isfinite(v); }
inline bool IsFinite(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Orthonormal basis around a unit normal (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
inline void OrthonormalBasis(const Vec3& n, Vec3& t, Vec3& b) {
  const float sign = std::copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z);
  const float bb = n.x * n.y * a;
  t = Vec3(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
  b = Vec3(bb, sign + n.y * n.y * a, -n.y);
}

}  // namespace restir
