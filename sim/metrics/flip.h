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
// count and SIMD target (blocks of rows go to tbb::parallel_for tasks, each pixel's value, HDR-FLIP's maximum over
// the exposures included, is computed within one task), and the means are summed sequentially in pixel order in
// double. The implementation (sim/metrics/flip.cpp, flip_passes.cpp, flip_rows.cpp) reproduces its first version bit
// for bit; tests/sim/metrics/flip_legacy_test.cpp keeps that version as the oracle.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "sim/util/image.h"

namespace restir {

namespace flip_detail {
struct ReferencePlanes;  // sim/metrics/flip_internal.h
}

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
// Y_median is the luminance at index n / 2 in sorted order (the upper middle one for an even n), as NVIDIA's FLIP
// takes it: tests/sim/metrics/flip_nvidia_test.cpp holds the two to 1e-5 in the mean.
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

// HDR-FLIP's work on the reference alone, done once and reused for every test image compared with it (the run
// compares each frame's reference with every preset's image): the exposure range and, per exposure, the
// reference's per-pixel Hunt-adjusted L*a*b* and edge and point magnitudes after both filter passes. Holds
// 5 floats per pixel (rows padded to a multiple of 16) per exposure, Bytes(): 40 MB at 640x360 with 9 exposures,
// 370 MB at 1920x1080. Immutable; copies share the planes.
class FlipReference {
 public:
  explicit FlipReference(const ImageRgb& reference, double ppd = kFlipDefaultPpd);

  int Width() const { return width_; }
  int Height() const { return height_; }
  double Ppd() const { return ppd_; }
  const FlipExposureRange& Range() const { return range_; }
  // Heap bytes held (the per-exposure planes).
  size_t Bytes() const;

 private:
  friend FlipMap HdrFlip(const FlipReference& reference, const ImageRgb& test, FlipExposureRange* range);
  int width_ = 0, height_ = 0;
  double ppd_ = kFlipDefaultPpd;
  FlipExposureRange range_;
  std::shared_ptr<const flip_detail::ReferencePlanes> planes_;  // immutable: copies share it
};

// HDR-FLIP of a test image against a prepared reference, bit for bit the map of HdrFlip(reference image, test,
// ppd). `range`, when given, receives the exposures used.
FlipMap HdrFlip(const FlipReference& reference, const ImageRgb& test, FlipExposureRange* range = nullptr);

// HDR-FLIP of two linear HDR images (negative values and NaN count as 0, +inf tone-maps to 1). Not symmetric:
// the exposure range comes from the reference. `range`, when given, receives the exposures used. Prepares the
// reference for this one call: comparing several images with one reference, build a FlipReference once.
FlipMap HdrFlip(const ImageRgb& reference, const ImageRgb& test, double ppd = kFlipDefaultPpd,
                FlipExposureRange* range = nullptr);

// Mean of a map over every pixel, or over the pixels where mask[i] != 0 (0 when the mask selects none); summed
// in pixel order in double.
double MeanFlip(const FlipMap& map, const std::vector<uint8_t>* mask = nullptr);

// Exposure count the memory estimate assumes: the run cannot know it before the reference is rendered. It is
// ceil(log2(Y_max / Y_median)) of the reference: 8 or 9 for this project's sequences; 12 leaves room for a
// brightest pixel ten times brighter than theirs.
constexpr int kFlipEstimateExposures = 12;

// The bytes per pixel a frame's HDR-FLIP holds at its peak, for the run's memory estimate (sim/run/memory_estimate.h),
// at `exposures` exposures: the FlipReference's planes (5 floats per pixel and exposure) and an HdrFlip call's
// blocks in flight (at most 2 floats per pixel and exposure; less when the threads' blocks, 128 rows at most, do
// not cover the image). Nothing else grows with the pixel count and coexists with them: the FlipReference's
// construction first holds the reference's luminances (a double per pixel, freed before the planes are allocated),
// a call returns its map (counted with each preset's images), and the row padding (to a multiple of 16 pixels) and
// the per-thread row buffers grow with the width only.
size_t HdrFlipScratchBytesPerPixel(int exposures = kFlipEstimateExposures);

}  // namespace restir
