#include <cmath>

#include "sim/scene/sequence.h"

namespace restir {

Vec3 Camera::RayDirection(float px, float py) const {
  const float tanHalf = std::tan(0.5f * glm::radians(vfovDegrees));
  const float aspect = static_cast<float>(width) / static_cast<float>(height);
  const float sx = (2.0f * px / static_cast<float>(width) - 1.0f) * tanHalf * aspect;
  const float sy = (1.0f - 2.0f * py / static_cast<float>(height)) * tanHalf;
  return glm::normalize(forward + sx * right + sy * up);
}

bool Camera::Project(const Vec3& world, float& px, float& py) const {
  const Vec3 d = world - position;
  const float z = glm::dot(d, forward);
  if (!(z > 1e-6f)) return false;
  const float tanHalf = std::tan(0.5f * glm::radians(vfovDegrees));
  const float aspect = static_cast<float>(width) / static_cast<float>(height);
  const float sx = glm::dot(d, right) / (z * tanHalf * aspect);
  const float sy = glm::dot(d, up) / (z * tanHalf);
  px = 0.5f * (sx + 1.0f) * static_cast<float>(width);
  py = 0.5f * (1.0f - sy) * static_cast<float>(height);
  return std::isfinite(px) && std::isfinite(py);
}

}  // namespace restir
