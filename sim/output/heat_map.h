// The colour maps of the report's and the videos' per-pixel maps, and the per-pixel quantities they show: one
// definition, so that a report strip, a scrubber frame and a video frame of the same pixel agree.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "sim/util/image.h"

namespace restir {

// An sRGB-encoded colour, each channel 0..1.
struct Rgb {
  double r, g, b;
};

// Polynomial fits of matplotlib's colour maps (Matt Zucker, CC0), t in [0, 1].
enum class ColourMap {
  kInferno,  // the error heat map
  kMagma,    // the FLIP map
};
Rgb MapColour(ColourMap map, double t);

// A CSS linear-gradient of the map from 0 (left) to 1 (right): the legend beside its images.
std::string CssGradient(ColourMap map);

// One pixel's relative error, the square root of its relmse term: sqrt(mean over RGB of e_c² / (R_c² + 0.01)), with
// e the estimate minus the reference (docs/metrics.md, relmse). Shown as 0..1 on the error map.
double PixelRelativeError(const float e[3], const float r[3]);

// A map is shown in 256 levels: value v (clamped to [0, 1], non-finite as 1) is level lround(255 v), coloured
// MapColour(level / 255). The same pixels as an RGB image or as a palette PNG (sim/output/png_encode.h).
std::array<unsigned char, 256 * 3> HeatMapPalette(ColourMap map);
std::vector<unsigned char> HeatMapLevels(const std::vector<double>& values);
// The levels through the palette: 8-bit RGB, 3 bytes a pixel.
std::vector<unsigned char> HeatMapRgb(const std::vector<double>& values, ColourMap map);

// The error map's values: PixelRelativeError of an estimate against its reference, per pixel.
std::vector<double> RelativeErrorValues(const ImageRgb& estimate, const ImageRgb& reference);

}  // namespace restir
