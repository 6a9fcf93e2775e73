// The frames a person watches: every frame of a run as small 8-bit PNGs under OUT/scrub/, which report.html's frame
// scrubber shows and from which `restir-sim report` makes the videos (sim/output/video.h). They are written for every
// frame, whichever frames get their EXR (--images), because temporal artefacts (flicker, boiling, the recovery after
// a reveal) are judged by moving through the frames, not from three stills.
//
//   scrub/reference/NNNN.png             the reference, tone-mapped at the run's exposure
//   scrub/disocclusion/NNNN.png          255 where reprojection failed this frame, 96 where a pixel was revealed in
//                                        the last 4 frames, 0 elsewhere (grey, one byte a pixel)
//   scrub/presets/P/NNNN_estimate.png    the estimate at the same exposure as the reference
//   scrub/presets/P/NNNN_error.png       the error heat map (sim/output/heat_map.h), as the report's strips
//   scrub/presets/P/NNNN_flip.png        the FLIP map
//
// One exposure for the whole run (chosen from its first frame, kept across a resume), so that brightness in the
// videos changes only where the image does.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sim/util/image.h"

namespace restir {

// A preset's layers in the scrubber.
enum class ScrubLayer : uint8_t {
  kEstimate,
  kError,
  kFlip,
};
const char* ScrubLayerName(ScrubLayer layer);  // estimate, error, flip

// Paths relative to the run's output directory, '/'-separated.
std::string ScrubReferencePath(int frame);
std::string ScrubDisocclusionPath(int frame);
std::string ScrubPresetPath(const std::string& preset, int frame, ScrubLayer layer);

// The mask's grey levels.
inline constexpr unsigned char kScrubDisoccludedNow = 255;
inline constexpr unsigned char kScrubRevealedRecently = 96;

// A frame's shared scrub files (width x height). `reference` may be null (no reference: nothing written for it).
// `disoccluded` and `recent` are per pixel, nonzero where set. Each file is written atomically; returns the relative
// paths written.
std::vector<std::string> WriteScrubFrame(const std::string& outDir, int frame, int width, int height,
                                         const ImageRgb* reference, float exposure, const std::vector<uint8_t>& disoccluded,
                                         const std::vector<uint8_t>& recent);

// One preset's scrub files of a frame: the estimate always, the error and FLIP maps when there is a reference
// (`reference` non-null, `flip` one value per pixel). Returns the relative paths written.
std::vector<std::string> WriteScrubPreset(const std::string& outDir, const std::string& preset, int frame,
                                          const ImageRgb& estimate, const ImageRgb* reference,
                                          const std::vector<float>* flip, float exposure);

// Reads one of those PNGs back as 8-bit RGB (grey expanded), checking its size; throws InputError naming the file
// when it is unreadable or another size.
std::vector<unsigned char> ReadScrubPng(const std::string& path, int width, int height);

}  // namespace restir
