#include "sim/scene/sky_frame.h"

#include <cmath>

namespace restir {

void PrepareEnvironment(Environment& environment) {
  environment.sampler = std::make_shared<const EnvironmentSampler>(environment.map);
}

Sky MakeSky(const Sequence& sequence, const FrameState& state) {
  Sky sky;
  const Environment& e = sequence.environment;
  if (e.present && e.sampler != nullptr && state.environmentIntensity > 0.0f) {
    sky.environment = e.sampler.get();
    sky.environmentScale = Vec3(state.environmentIntensity);
    const double rho = double(state.environmentRotationDegrees) * M_PI / 180.0;
    sky.cosRotation = static_cast<float>(std::cos(rho));
    sky.sinRotation = static_cast<float>(std::sin(rho));
  }
  const Sun& s = sequence.sun;
  if (s.present && state.sunIntensity > 0.0f) {
    sky.hasSun = true;
    sky.sun = MakeSunDisc(state.sunDirection, s.angularDiameterDegrees, s.radiance * state.sunIntensity);
  }
  return sky;
}

}  // namespace restir
