// Per-frame image outputs: a single-part multi-layer EXR and a tone-mapped PNG preview.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sim/scene/gbuffer.h"
#include "sim/util/image.h"

namespace restir {

// The layers of one frame's EXR. The estimate is the unnamed default layer (R, G, B); the rest are named
// layers: reference.{R,G,B}, reference_stderr.{R,G,B}, error.{R,G,B} (estimate - reference),
// disocclusion.Y (1 where reprojection failed), depth.Z (view depth), normal.{X,Y,Z} (shading normal) and
// flip.Y (per-pixel HDR-FLIP of the estimate against the reference, sim/metrics/flip.h).
struct FrameLayers {
  const ImageRgb* estimate = nullptr;
  const ImageRgb* reference = nullptr;      // may be null (--no-reference): reference and error layers omitted
  const ImageRgb* referenceStdError = nullptr;
  const std::vector<float>* flip = nullptr;  // may be null (no reference): flip layer omitted
  const ImageRgb* ensembleBias = nullptr;      // --ensemble K: mean of the K estimates minus the reference
  const ImageRgb* ensembleVariance = nullptr;  // --ensemble K: per-pixel variance of the K estimates
  const GBuffer* gbuffer = nullptr;
  // The sequence's content hash (run.json's sequence.contentHash), stored as the string attribute
  // "restir:sequenceHash" so that `report` can tell a frame of this run from a file put in its place; "": none.
  std::string sequenceHash;
};

// How the EXRs store their channels. The pixels are the same bits whichever is chosen; only the files' size and the
// CPU time spent writing them differ (the flagship's 640x360 EXR with every layer: stored 16.6 MB, zip 9.0 MB; on
// every frame of README command 1, run-length cost about 5% more of the run's CPU, zip more still).
enum class ExrCompression : uint8_t {
  kNone,  // NO_COMPRESSION: the cheapest to write and to read
  kRle,   // RLE_COMPRESSION: run-length, per scanline
  kZip,   // ZIP_COMPRESSION: deflate, 16 scanlines a chunk; the default (a run writes few EXRs, --images)
};
const char* ExrCompressionName(ExrCompression c);  // none, rle, zip
std::optional<ExrCompression> ParseExrCompression(const std::string& name);

// A frame's number as every per-frame file names it: four digits at least, "0007".
std::string FrameNumber(int frame);

void WriteFrameExr(const std::string& path, const FrameLayers& layers,
                   ExrCompression compression = ExrCompression::kNone);

// Threads OpenEXR's own pool uses to compress a file's chunks (0: on the calling thread). The run sets it to its
// --threads; the bytes written do not depend on it.
void SetExrThreads(int threads);

// Estimate beside reference (or the estimate alone), both with one exposure chosen from the reference
// (or estimate) so that its 90th luminance percentile maps to 0.8 (emitters saturate), clamped, sRGB, 8 bits.
void WritePreviewPng(const std::string& path, const ImageRgb& estimate, const ImageRgb* reference);

// The parts of that preview, for runs that write many previews of one reference (its panel and the exposure are
// the same for every preset's): the exposure chosen from an image, an image tone-mapped at an exposure (rows top
// to bottom, 3 bytes a pixel), and panels of w x h such bytes side by side as the PNG at `path`.
float PreviewExposure(const ImageRgb& exposureSource);
// A linear value's 8-bit preview code: lround(255 sRGB(clamp(v, 0, 1))), non-finite values 0.
unsigned char PreviewByte(float linear);
std::vector<unsigned char> TonemapPreview(const ImageRgb& img, float exposure);
void WritePreviewPng(const std::string& path, const std::vector<const std::vector<unsigned char>*>& panels, int w,
                     int h);

// An 8-bit RGB image (w x h, rows top to bottom, 3 bytes a pixel) encoded as PNG, in memory, so that the bytes
// reach their file through WriteFileAtomic's checked writes (sim/util/atomic_file.h) rather than the codec's own.
std::string EncodePng(const std::vector<unsigned char>& rgb, int w, int h, bool srgb);

}  // namespace restir
