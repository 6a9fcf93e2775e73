#include "sim/output/scrub_frames.h"

#include <OpenImageIO/imageio.h>

#include <filesystem>

#include "sim/output/frame_writer.h"
#include "sim/output/heat_map.h"
#include "sim/output/png_encode.h"
#include "sim/util/atomic_file.h"
#include "sim/util/input_error.h"
#include "sim/util/input_file.h"
#include "sim/util/text.h"

namespace restir {

namespace {

// WriteFileAtomic makes the directories, and names the file when it cannot (exit status 2, not a crash).
void Write(const std::string& outDir, const std::string& relative, const std::string& png) {
  WriteFileAtomic((std::filesystem::path(outDir) / relative).string(), png);
}

}  // namespace

const char* ScrubLayerName(ScrubLayer layer) {
  switch (layer) {
    case ScrubLayer::kEstimate: return "estimate";
    case ScrubLayer::kError: return "error";
    case ScrubLayer::kFlip: return "flip";
  }
  return "?";
}

std::string ScrubReferencePath(int frame) { return "scrub/reference/" + FrameNumber(frame) + ".png"; }
std::string ScrubDisocclusionPath(int frame) { return "scrub/disocclusion/" + FrameNumber(frame) + ".png"; }
std::string ScrubPresetPath(const std::string& preset, int frame, ScrubLayer layer) {
  return "scrub/presets/" + preset + "/" + FrameNumber(frame) + "_" + ScrubLayerName(layer) + ".png";
}

std::vector<std::string> WriteScrubFrame(const std::string& outDir, int frame, int width, int height,
                                         const ImageRgb* reference, float exposure, const std::vector<uint8_t>& disoccluded,
                                         const std::vector<uint8_t>& recent) {
  std::vector<std::string> written;
  if (reference) {
    written.push_back(ScrubReferencePath(frame));
    Write(outDir, written.back(),
          EncodeRgbPng(TonemapPreview(*reference, exposure), reference->width, reference->height));
  }
  std::vector<unsigned char> mask(disoccluded.size());
  for (size_t i = 0; i < mask.size(); ++i)
    mask[i] = disoccluded[i] ? kScrubDisoccludedNow : i < recent.size() && recent[i] ? kScrubRevealedRecently : 0;
  written.push_back(ScrubDisocclusionPath(frame));
  Write(outDir, written.back(), EncodeGreyPng(mask, width, height));
  return written;
}

std::vector<std::string> WriteScrubPreset(const std::string& outDir, const std::string& preset, int frame,
                                          const ImageRgb& estimate, const ImageRgb* reference,
                                          const std::vector<float>* flip, float exposure) {
  const int w = estimate.width, h = estimate.height;
  std::vector<std::string> written;
  written.push_back(ScrubPresetPath(preset, frame, ScrubLayer::kEstimate));
  Write(outDir, written.back(), EncodeRgbPng(TonemapPreview(estimate, exposure), w, h));
  if (reference) {
    written.push_back(ScrubPresetPath(preset, frame, ScrubLayer::kError));
    Write(outDir, written.back(),
          EncodeIndexedPng(HeatMapLevels(RelativeErrorValues(estimate, *reference)), w, h,
                           HeatMapPalette(ColourMap::kInferno)));
  }
  if (flip) {
    written.push_back(ScrubPresetPath(preset, frame, ScrubLayer::kFlip));
    Write(outDir, written.back(),
          EncodeIndexedPng(HeatMapLevels(std::vector<double>(flip->begin(), flip->end())), w, h,
                           HeatMapPalette(ColourMap::kMagma)));
  }
  return written;
}

std::vector<unsigned char> ReadScrubPng(const std::string& path, int width, int height) {
  std::string bytes, problem;
  if (!TryReadRegularFile(path, size_t(1) << 30, bytes, problem))
    throw InputError(OneLine(path + ": error: cannot read (" + problem + ")"));
  if (!PngIsWhole(bytes)) throw InputError(path + ": error: cannot read (not a whole PNG: cut short or damaged)");
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw InputError(OneLine(path + ": error: cannot read (" + OIIO::geterror() + ")"));
  const OIIO::ImageSpec spec = in->spec();
  if (spec.width != width || spec.height != height || (spec.nchannels != 1 && spec.nchannels != 3))
    throw InputError(path + ": error: not a frame of this run (" + std::to_string(spec.width) + "x" +
                     std::to_string(spec.height) + " with " + std::to_string(spec.nchannels) + " channels where the run's frames are " +
                     std::to_string(width) + "x" + std::to_string(height) + ")");
  std::vector<unsigned char> px(static_cast<size_t>(width) * height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, px.data()))
    throw InputError(OneLine(path + ": error: cannot read (" + in->geterror() + ")"));
  if (spec.nchannels == 3) return px;
  std::vector<unsigned char> rgb(px.size() * 3);
  for (size_t i = 0; i < px.size(); ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = px[i];
  return rgb;
}

}  // namespace restir
