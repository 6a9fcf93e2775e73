// FLIP's public functions (sim/metrics/flip.h): the exposure range, LDR-FLIP, FlipReference and HDR-FLIP, and how their
// work is split into tasks. The filter passes are in sim/metrics/flip_passes.cpp, their SIMD stages in
// sim/metrics/flip_rows.cpp.
#include "sim/metrics/flip.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "sim/metrics/flip_internal.h"

namespace restir {

namespace {

using namespace flip_detail;

// Tone-mapped value the brightest pixel reaches at the start exposure and the median at the stop exposure.
constexpr double kToneTarget = 0.85;

// The image split into blocks of rows; a task is one block at one exposure (a FlipReference's planes, LDR-FLIP).
// Each task redoes the horizontal pass for the `pad` rows either side of its block (the vertical filters' reach),
// so blocks are kept tall: just enough of them that every thread gets a few tasks (equal tasks balance; the rows'
// work is nearly uniform).
struct TaskGrid {
  int rowsPerBlock = 1, blocks = 1;
  TaskGrid(int height, int exposures, int pad) {
    const int threads = std::max(1, tbb::this_task_arena::max_concurrency());
    const int wanted = (8 * threads + exposures - 1) / exposures;
    const int most = std::max(1, height / std::max(1, 4 * pad));  // blocks at least 4 pads tall
    blocks = std::clamp(wanted, 1, most);
    rowsPerBlock = (height + blocks - 1) / blocks;
    blocks = (height + rowsPerBlock - 1) / rowsPerBlock;
  }
  int Tasks(int exposures) const { return blocks * exposures; }
};

// HdrFlip's tasks: a block of rows at every exposure, so that each pixel's maximum over the exposures is taken in
// one place (BoundsRow, then the exact values of the candidates); the block keeps every exposure's HyAB and feature
// difference meanwhile (8 bytes per pixel and exposure). Blocks are tall, for the horizontal pass's overlap: a
// multiple of the thread count of them (equal blocks balance), at most kMaxRows rows (the memory), at least 4 pads
// unless the image is shorter.
struct BlockGrid {
  static constexpr int kMaxRows = 128;
  int rowsPerBlock = 1, blocks = 1;
  BlockGrid(int height, int pad) {
    const int threads = std::max(1, tbb::this_task_arena::max_concurrency());
    blocks = threads * ((height + threads * kMaxRows - 1) / (threads * kMaxRows));
    blocks = std::clamp(blocks, 1, std::max(1, height / std::max(1, 4 * pad)));
    rowsPerBlock = (height + blocks - 1) / blocks;
    blocks = (height + rowsPerBlock - 1) / rowsPerBlock;
  }
};

// A reference's features at each tone: [tone][plane][row][stride].
ReferencePlanes AnalyseReference(const ImageRgb& image, const FlipKernels& k, const std::vector<double>& scales) {
  const int w = image.width, h = image.height, stride = RowStride(w);
  const size_t planeSize = size_t(h) * stride;
  ReferencePlanes planes;
  planes.stride = stride;
  planes.values.resize(scales.size() * kFeaturePlanes * planeSize);
  float* out = planes.values.data();
  const int tones = static_cast<int>(scales.size());
  const TaskGrid grid(h, tones, k.pad);
  tbb::enumerable_thread_specific<Scratch> scratch(w, k.pad);
  tbb::parallel_for(0, grid.Tasks(tones), [&](int task) {
    const int e = task / grid.blocks, b = task % grid.blocks;
    const int y0 = b * grid.rowsPerBlock, y1 = std::min(h, y0 + grid.rowsPerBlock);
    Scratch& s = scratch.local();
    Analyse(image, k, scales[size_t(e)], y0, y1, s, [&](int y) {
      for (int p = 0; p < kFeaturePlanes; ++p)
        std::memcpy(out + (size_t(e) * kFeaturePlanes + p) * planeSize + size_t(y) * stride, s.Feature(p),
                    size_t(stride) * sizeof(float));
    });
  });
  return planes;
}

// LDR-FLIP's comparison: the test image against the reference's features at each tone. Per row and tone,
// sink(tone, y, flip, color, feature) gets the row's [0, width) values; it runs on the tasks' threads, rows of one
// tone never twice.
template <class Sink>
void CompareWithReference(const ImageRgb& test, const FlipKernels& k, const std::vector<double>& scales,
                          const ReferencePlanes& reference, Sink sink) {
  const int w = test.width, h = test.height, stride = RowStride(w);
  const float cmax = MaxHyabPow();
  const int tones = static_cast<int>(scales.size());
  const TaskGrid grid(h, tones, k.pad);
  tbb::enumerable_thread_specific<Scratch> scratch(w, k.pad);
  tbb::parallel_for(0, grid.Tasks(tones), [&](int task) {
    const int e = task / grid.blocks, b = task % grid.blocks;
    const int y0 = b * grid.rowsPerBlock, y1 = std::min(h, y0 + grid.rowsPerBlock);
    Scratch& s = scratch.local();
    Analyse(test, k, scales[size_t(e)], y0, y1, s, [&](int y) {
      const float* ref[kFeaturePlanes];
      const float* tst[kFeaturePlanes];
      for (int p = 0; p < kFeaturePlanes; ++p) {
        ref[p] = reference.Row(e, p, y, h);
        tst[p] = s.Feature(p);
      }
      float *hyab = s.Compare(0), *feature = s.Compare(1), *color = s.Compare(2), *flip = s.Compare(3);
      DifferenceRow(ref, tst, stride, hyab, feature);
      for (int x = 0; x < w; ++x) {  // FlipFromDifferences, keeping its colour and feature terms
        feature[x] = FeatureTerm(feature[x]);
        color[x] = Redistribute(PowOrShortcut(hyab[x], kQc), cmax);
        flip[x] = Clamp01(PowOrShortcut(color[x], 1.0f - feature[x]));
      }
      sink(e, y, flip, color, feature);
    });
  });
}

void CheckInputs(const ImageRgb& reference, const ImageRgb& test, double ppd) {
  if (reference.width != test.width || reference.height != test.height)
    throw std::invalid_argument("FLIP: reference and test images differ in size");
  if (reference.Size() != static_cast<size_t>(reference.width) * reference.height ||
      test.Size() != reference.Size())
    throw std::invalid_argument("FLIP: image pixel count does not match its size");
  if (!(ppd > 0.0) || !std::isfinite(ppd)) throw std::invalid_argument("FLIP: pixels per degree must be > 0");
}

// x at which the tone mapper reaches t: the positive root of (k0 - k3 t) x² + (k1 - k4 t) x + (k2 - k5 t) = 0.
double ToneMapInverse(double t) {
  const double c0 = (kTm1 - kTm4 * t) / (kTm0 - kTm3 * t);
  const double c1 = (kTm2 - kTm5 * t) / (kTm0 - kTm3 * t);
  return -0.5 * c0 + std::sqrt(0.25 * c0 * c0 - c1);
}

// The median as NVIDIA's FLIP takes it (FLIP.h, computeExposures): the value at index n / 2 of the sorted values,
// so the upper of the two middle values for an even count. Averaging the two instead moves the stop exposure,
// hence every exposure, whenever they differ (issue 16: up to 0.033 in the mean on tests/data/flip_nvidia/).
double Median(std::vector<double> v) {
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

std::vector<double> ExposureScales(const FlipExposureRange& range) {
  std::vector<double> scales;
  for (int e = 0; e < range.count; ++e) scales.push_back(std::exp2(range.Exposure(e)));
  return scales;
}

}  // namespace

float FlipSrgbToLinear(float v) {
  return v > 0.04045f ? std::pow((v + 0.055f) / 1.055f, 2.4f) : v / 12.92f;
}

float FlipAcesToneMap(float value, double exposure) {
  return static_cast<float>(ToneMapX(std::exp2(exposure) * double(value)));
}

FlipExposureRange FlipExposures(const ImageRgb& reference) {
  std::vector<double> lum;
  lum.reserve(reference.Size());
  double yMax = 0.0;
  for (const Vec3& p : reference.pixels) {
    auto channel = [](float c) { return c > 0.0f ? double(c) : 0.0; };  // negative and NaN count as 0
    const double y = Luminance(glm::dvec3(channel(p.x), channel(p.y), channel(p.z)));
    if (!std::isfinite(y)) continue;  // +inf tone-maps to 1 at every exposure
    lum.push_back(y);
    yMax = std::max(yMax, y);
  }
  FlipExposureRange range;
  if (lum.empty() || yMax <= 0.0) return range;  // black reference: exposures 0 and 0
  double yMedian = Median(lum);
  if (yMedian <= 0.0) {
    lum.erase(std::remove_if(lum.begin(), lum.end(), [](double y) { return y <= 0.0; }), lum.end());
    yMedian = Median(lum);
  }
  const double xTarget = ToneMapInverse(kToneTarget);
  range.start = std::log2(xTarget / yMax);
  range.stop = std::log2(xTarget / yMedian);
  range.count = std::max(2, static_cast<int>(std::ceil(range.stop - range.start)));
  return range;
}

LdrFlipComponents LdrFlipWithComponents(const ImageRgb& reference, const ImageRgb& test, double ppd) {
  CheckInputs(reference, test, ppd);
  LdrFlipComponents out;
  out.flip.width = reference.width;
  out.flip.height = reference.height;
  out.flip.values.resize(reference.Size());
  out.color.resize(reference.Size());
  out.feature.resize(reference.Size());
  if (reference.Size() == 0) return out;
  const FlipKernels kernels(ppd);
  const std::vector<double> ldr{0.0};  // one tone: clamp to [0, 1]
  const size_t w = size_t(reference.width);
  CompareWithReference(test, kernels, ldr, AnalyseReference(reference, kernels, ldr),
                       [&](int, int y, const float* flip, const float* color, const float* feature) {
                         std::copy(flip, flip + w, out.flip.values.begin() + ptrdiff_t(y * w));
                         std::copy(color, color + w, out.color.begin() + ptrdiff_t(y * w));
                         std::copy(feature, feature + w, out.feature.begin() + ptrdiff_t(y * w));
                       });
  return out;
}

FlipMap LdrFlip(const ImageRgb& reference, const ImageRgb& test, double ppd) {
  return LdrFlipWithComponents(reference, test, ppd).flip;
}

FlipReference::FlipReference(const ImageRgb& reference, double ppd)
    : width_(reference.width), height_(reference.height), ppd_(ppd) {
  CheckInputs(reference, reference, ppd);
  range_ = FlipExposures(reference);
  planes_ = std::make_shared<const ReferencePlanes>(
      reference.Size() ? AnalyseReference(reference, FlipKernels(ppd), ExposureScales(range_)) : ReferencePlanes());
}

size_t FlipReference::Bytes() const { return planes_->values.capacity() * sizeof(float); }

FlipMap HdrFlip(const FlipReference& reference, const ImageRgb& test, FlipExposureRange* rangeOut) {
  if (reference.width_ != test.width || reference.height_ != test.height)
    throw std::invalid_argument("FLIP: reference and test images differ in size");
  if (test.Size() != static_cast<size_t>(test.width) * test.height)
    throw std::invalid_argument("FLIP: image pixel count does not match its size");
  if (rangeOut) *rangeOut = reference.range_;
  FlipMap out;
  out.width = test.width;
  out.height = test.height;
  out.values.assign(test.Size(), 0.0f);
  if (out.values.empty()) return out;
  const FlipKernels kernels(reference.ppd_);
  const std::vector<double> scales = ExposureScales(reference.range_);
  const int exposures = reference.range_.count, w = test.width, h = test.height, stride = RowStride(w);
  const size_t exposureStride = 2 * size_t(stride);  // a row's HyAB, then its feature difference, per exposure
  const float cmax = MaxHyabPow();
  const BlockGrid grid(h, kernels.pad);
  struct BlockScratch {
    Scratch rows;
    AlignedFloats differences;  // [row of the block][exposure][HyAB, feature difference][stride]
    AlignedFloats hi, maxLo;    // BoundsRow's: [exposure][stride], [stride]
    BlockScratch(int width, int pad, int rowsPerBlock, int exposures)
        : rows(width, pad),
          differences(size_t(rowsPerBlock) * exposures * 2 * RowStride(width)),
          hi(size_t(exposures) * RowStride(width)),
          maxLo(size_t(RowStride(width))) {}
  };
  tbb::enumerable_thread_specific<BlockScratch> scratch(w, kernels.pad, grid.rowsPerBlock, exposures);
  tbb::parallel_for(0, grid.blocks, [&](int b) {
    const int y0 = b * grid.rowsPerBlock, y1 = std::min(h, y0 + grid.rowsPerBlock);
    BlockScratch& s = scratch.local();
    auto hyabRow = [&](int y, int e) {
      return s.differences.data() + (size_t(y - y0) * exposures + e) * exposureStride;
    };
    for (int e = 0; e < exposures; ++e) {
      Analyse(test, kernels, scales[size_t(e)], y0, y1, s.rows, [&](int y) {
        const float* ref[kFeaturePlanes];
        const float* tst[kFeaturePlanes];
        for (int p = 0; p < kFeaturePlanes; ++p) {
          ref[p] = reference.planes_->Row(e, p, y, h);
          tst[p] = s.rows.Feature(p);
        }
        DifferenceRow(ref, tst, stride, hyabRow(y, e), hyabRow(y, e) + stride);
      });
    }
    for (int y = y0; y < y1; ++y) {
      const float* hyab = hyabRow(y, 0);
      const float* featureDiff = hyab + stride;
      BoundsRow(hyab, featureDiff, exposureStride, exposures, stride, cmax, s.hi.data(), s.maxLo.data());
      float* row = out.values.data() + size_t(y) * w;
      for (int x = 0; x < w; ++x) {
        // The pre-optimisation code took std::max over every exposure, in order, from 0. FLIP values are never
        // NaN or -0, so the maximum over the candidates, in any order, is the same bits.
        float best = 0.0f;
        for (int e = 0; e < exposures; ++e) {
          if (!(s.hi[size_t(e) * stride + x] >= s.maxLo[x])) continue;  // provably below another exposure's
          const size_t i = size_t(e) * exposureStride + x;
          best = std::max(best, FlipFromDifferences(hyab[i], featureDiff[i], cmax));
        }
        row[x] = best;
      }
    }
  });
  return out;
}

FlipMap HdrFlip(const ImageRgb& reference, const ImageRgb& test, double ppd, FlipExposureRange* range) {
  CheckInputs(reference, test, ppd);
  return HdrFlip(FlipReference(reference, ppd), test, range);
}

size_t HdrFlipScratchBytesPerPixel(int exposures) {
  // 5 floats (the FlipReference) and at most 2 (HdrFlip's blocks in flight) per pixel and exposure.
  return size_t(std::max(exposures, 2)) * (kFeaturePlanes + 2) * sizeof(float);
}

double MeanFlip(const FlipMap& map, const std::vector<uint8_t>* mask) {
  double sum = 0.0;
  size_t n = 0;
  for (size_t i = 0; i < map.values.size(); ++i) {
    if (mask && !(*mask)[i]) continue;
    sum += map.values[i];
    ++n;
  }
  return n ? sum / double(n) : 0.0;
}

}  // namespace restir
