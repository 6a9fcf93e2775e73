// FLIP image difference (DESIGN §6 `flip`).
//
// LDR-FLIP: Andersson, Nilsson, Akenine-Möller, Oskarsson, Åström, Fairchild 2020, "FLIP: A Difference Evaluator
// for Alternating Images" (HPG 2020). HDR-FLIP: Andersson, Nilsson, Shirley, Akenine-Möller 2021, "Visualizing
// Errors in Rendered High Dynamic Range Images" (Eurographics 2021) and "Visualizing and Communicating Errors in
// Rendered Images" (Ray Tracing Gems II, 2021).
//
// Per-pixel error in [0, 1]; 0 means "no visible difference when flipping between the two images". Our images
// are linear HDR radiance, so the `flip` metric is HDR-FLIP: the per-pixel maximum of LDR-FLIP over a range of
// exposures of the ACES-tone-mapped pair, the range taken from the reference's luminance.
//
// Deterministic: every output pixel is computed by the same operations in the same order whatever the thread
// count (rows are distributed with tbb::parallel_for, nothing is reduced across threads), and the means are
// summed sequentially in pixel order in double.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "sim/image.h"

namespace restir {

// Pixels per degree of visual angle for an observer `distance` metres from a monitor `monitorWidth` metres wide
// showing `monitorPixels` pixels across: distance * (monitorPixels / monitorWidth) * pi / 180.
constexpr double FlipPixelsPerDegree(double distance, double monitorWidth, double monitorPixels) {
  return distance * (monitorPixels / monitorWidth) * (3.14159265358979323846 / 180.0);
}

// The papers' default viewing conditions: 0.7 m from a 0.7 m wide 3840-pixel monitor (about 67.02 ppd).
constexpr double kFlipDefaultPpd = FlipPixelsPerDegree(0.7, 0.7, 3840.0);

// One per-pixel map (row-major, y down) of FLIP values in [0, 1].
struct FlipMap {
  int width = 0;
  int height = 0;
  std::vector<float> values;
};

// LDR-FLIP and its two pipelines, per pixel: flip = color^(1 - feature).
struct LdrFlipComponents {
  FlipMap flip;
  std::vector<float> color;    // ΔE_c: HyAB of the CSF-filtered, Hunt-adjusted L*a*b* colours, redistributed
  std::vector<float> feature;  // ΔE_f: edge / point difference of the achromatic channel, to the power q_f
};

// LDR-FLIP of two images given as linear sRGB-primaries values in [0, 1] (values outside, NaN included, are
// clamped into it). 8-bit sRGB-encoded pictures must be decoded to linear first (FlipSrgbToLinear). Symmetric in
// its two arguments.
FlipMap LdrFlip(const ImageRgb& reference, const ImageRgb& test, double ppd = kFlipDefaultPpd);
LdrFlipComponents LdrFlipWithComponents(const ImageRgb& reference, const ImageRgb& test,
                                        double ppd = kFlipDefaultPpd);

// sRGB transfer function decode (for LDR pictures stored sRGB-encoded).
float FlipSrgbToLinear(float v);

// HDR-FLIP's default tone mapper: Narkowicz's fit of the ACES curve with its 0.6 pre-exposure folded into the
// coefficients, (k0 x² + k1 x) / (k3 x² + k4 x + k5), clamped to [0, 1]; x = 2^exposure * max(value, 0).
float FlipAcesToneMap(float value, double exposure);

// Exposures HDR-FLIP evaluates: start = log2(x_max / Y_max), stop = log2(x_max / Y_median), where Y is the
// reference's luminance and x_max solves tonemap(x) = 0.85; count = max(2, ceil(stop - start)), evenly spaced.
struct FlipExposureRange {
  double start = 0.0;
  double stop = 0.0;
  int count = 2;
  double Exposure(int i) const { return start + i * (stop - start) / double(count > 1 ? count - 1 : 1); }
};
// Guards the papers leave open: a black reference (Y_max = 0) evaluates exposures 0 and 0; when more than half
// the pixels are black (Y_median = 0, which would make the stop exposure infinite) the median of the positive
// luminances is used instead.
FlipExposureRange FlipExposures(const ImageRgb& reference);

// HDR-FLIP of two linear HDR images (negative values and NaN count as 0, +inf tone-maps to 1). Not symmetric:
// the exposure range comes from the reference. `range`, when given, receives the exposures used.
FlipMap HdrFlip(const ImageRgb& reference, const ImageRgb& test, double ppd = kFlipDefaultPpd,
                FlipExposureRange* range = nullptr);

// Mean of a map over every pixel, or over the pixels where mask[i] != 0 (0 when the mask selects none); summed
// in pixel order in double.
double MeanFlip(const FlipMap& map, const std::vector<uint8_t>* mask = nullptr);

// The bytes per pixel HdrFlip allocates while it runs (its filter planes and the luminances for the exposure
// range), for the run's memory estimate (sim/memory_estimate.h).
size_t HdrFlipScratchBytesPerPixel();

}  // namespace restir
