#include "sim/metrics.h"

#include <cmath>

namespace restir {

AccuracyMetrics MeasureAccuracy(const ImageRgb& estimate, const ImageRgb& reference,
                                const std::vector<uint8_t>* mask) {
  AccuracyMetrics m;
  double se = 0.0, seLuma = 0.0, rel = 0.0, sumY = 0.0, sumYRef = 0.0, spe = 0.0;
  size_t count = 0, litCount = 0;
  for (size_t i = 0; i < estimate.Size(); ++i) {
    if (mask && !(*mask)[i]) continue;
    const Vec3& a = estimate.pixels[i];
    const Vec3& r = reference.pixels[i];
    for (int c = 0; c < 3; ++c) {
      const double d = double(a[c]) - double(r[c]);
      se += d * d;
      rel += d * d / (double(r[c]) * double(r[c]) + 0.01);
    }
    const double ya = Luminance(a), yr = Luminance(r);
    seLuma += (ya - yr) * (ya - yr);
    if (yr > 1e-4) {
      spe += ((ya - yr) / yr) * ((ya - yr) / yr);
      ++litCount;
    }
    sumY += ya;
    sumYRef += yr;
    ++count;
  }
  m.pixels = count;
  if (count == 0) return m;
  m.rmse = std::sqrt(se / (3.0 * count));
  m.lumaRmse = std::sqrt(seLuma / count);
  m.relmse = rel / (3.0 * count);
  m.lumaRatio = sumYRef > 0.0 ? sumY / sumYRef : (sumY > 0.0 ? INFINITY : 1.0);
  m.rmspe = litCount ? std::sqrt(spe / double(litCount)) : 0.0;
  m.lumaSum = sumY;
  m.referenceLumaSum = sumYRef;
  return m;
}

double StabilityLumaRmse(const ImageRgb& current, const ImageRgb& previous) {
  double sum = 0.0;
  for (size_t i = 0; i < current.Size(); ++i) {
    const double d = double(Luminance(current.pixels[i])) - double(Luminance(previous.pixels[i]));
    sum += d * d;
  }
  return current.Size() ? std::sqrt(sum / double(current.Size())) : 0.0;
}

double Flicker(const ImageRgb& current, const ImageRgb& previous, const ImageRgb& reference,
               const ImageRgb& previousReference) {
  double sum = 0.0;
  for (size_t i = 0; i < current.Size(); ++i) {
    const double d = (double(Luminance(current.pixels[i])) - double(Luminance(previous.pixels[i]))) -
                     (double(Luminance(reference.pixels[i])) - double(Luminance(previousReference.pixels[i])));
    sum += d * d;
  }
  return current.Size() ? std::sqrt(sum / double(current.Size())) : 0.0;
}

double MaskFraction(const std::vector<uint8_t>& mask) {
  if (mask.empty()) return 0.0;
  size_t n = 0;
  for (uint8_t v : mask) n += v != 0;
  return double(n) / double(mask.size());
}

}  // namespace restir
