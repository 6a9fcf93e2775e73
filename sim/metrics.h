// Per-frame error metrics against the reference (DESIGN §6). Sums run sequentially in pixel order in double
// precision, so the numbers are the same whatever the thread count.
#pragma once

#include <cstdint>
#include <vector>

#include "sim/image.h"

namespace restir {

struct AccuracyMetrics {
  double rmse = 0.0;        // sqrt(mean over pixels and RGB of (I - R)^2)
  double lumaRmse = 0.0;    // sqrt(mean (Y(I) - Y(R))^2), seed 003 "LumaRMSE"
  double relmse = 0.0;      // mean over pixels and RGB of (I - R)^2 / (R^2 + 0.01)
  double lumaRatio = 0.0;   // sum Y(I) / sum Y(R); 1 means no bias in total brightness
  double rmspe = 0.0;       // sqrt(mean over pixels with Y(R) > 1e-4 of ((Y(I) - Y(R)) / Y(R))^2), seed 000
  double lumaSum = 0.0;     // sum Y(I), so ratios can be formed over many frames
  double referenceLumaSum = 0.0;  // sum Y(R)
  size_t pixels = 0;        // pixels the averages ran over
};

// Over every pixel, or over the pixels where mask[i] != 0 when a mask is given.
AccuracyMetrics MeasureAccuracy(const ImageRgb& estimate, const ImageRgb& reference,
                                const std::vector<uint8_t>* mask = nullptr);

// Per-frame stability (seed 003): sqrt(mean (Y(I_t) - Y(I_{t-1}))^2).
double StabilityLumaRmse(const ImageRgb& current, const ImageRgb& previous);

// Flicker net of real change: sqrt(mean ((Y(I_t) - Y(I_{t-1})) - (Y(R_t) - Y(R_{t-1})))^2).
double Flicker(const ImageRgb& current, const ImageRgb& previous, const ImageRgb& reference,
               const ImageRgb& previousReference);

// Fraction of pixels set in a mask.
double MaskFraction(const std::vector<uint8_t>& mask);

}  // namespace restir
