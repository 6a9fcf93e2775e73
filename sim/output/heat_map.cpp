#include "sim/output/heat_map.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace restir {

namespace {

const double kMagma[7][3] = {{-0.002136485053939582, -0.000749655052795221, -0.005386127855323933},
                             {0.2516605407371642, 0.6775232436837668, 2.494026599312351},
                             {8.353717279216625, -3.577719514958484, 0.3144679030132573},
                             {-27.66873308576866, 14.26473078096533, -13.64921318813922},
                             {52.17613981234068, -27.94360607168351, 12.94416944238394},
                             {-50.76852536473588, 29.04658282127291, 4.23415299384598},
                             {18.65570506591883, -11.48977351997711, -5.601961508734096}};
const double kInferno[7][3] = {{0.0002189403691192265, 0.001651004631001012, -0.01948089843709184},
                               {0.1065134194856116, 0.5639564367884091, 3.932712388889277},
                               {11.60249308247187, -3.972853965665698, -15.9423941062914},
                               {-41.70399613139459, 17.43639888205313, 44.35414519872813},
                               {77.162935699427, -33.40235894210092, -81.80730925738993},
                               {-71.31942824499214, 32.62606426397723, 73.20951985803202},
                               {25.13112622477341, -12.24266895238567, -23.07032500287172}};

}  // namespace

Rgb MapColour(ColourMap map, double t) {
  const double(*c)[3] = map == ColourMap::kMagma ? kMagma : kInferno;
  t = std::clamp(t, 0.0, 1.0);
  Rgb o{0, 0, 0};
  double* out[3] = {&o.r, &o.g, &o.b};
  for (int ch = 0; ch < 3; ++ch) {
    double v = c[6][ch];
    for (int k = 5; k >= 0; --k) v = c[k][ch] + t * v;
    *out[ch] = std::clamp(v, 0.0, 1.0);
  }
  return o;
}

std::string CssGradient(ColourMap map) {
  std::string s = "linear-gradient(to right";
  for (int i = 0; i <= 8; ++i) {
    const Rgb v = MapColour(map, i / 8.0);
    char buf[48];
    std::snprintf(buf, sizeof(buf), ", rgb(%d,%d,%d)", int(std::lround(v.r * 255)), int(std::lround(v.g * 255)),
                  int(std::lround(v.b * 255)));
    s += buf;
  }
  return s + ")";
}

double PixelRelativeError(const float e[3], const float r[3]) {
  double s = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double ek = e[k], rk = r[k];
    s += ek * ek / (rk * rk + 0.01);
  }
  return std::sqrt(s / 3.0);
}

std::array<unsigned char, 256 * 3> HeatMapPalette(ColourMap map) {
  std::array<unsigned char, 256 * 3> palette{};
  for (int k = 0; k < 256; ++k) {
    const Rgb c = MapColour(map, k / 255.0);
    palette[3 * k + 0] = static_cast<unsigned char>(std::lround(c.r * 255.0));
    palette[3 * k + 1] = static_cast<unsigned char>(std::lround(c.g * 255.0));
    palette[3 * k + 2] = static_cast<unsigned char>(std::lround(c.b * 255.0));
  }
  return palette;
}

std::vector<unsigned char> HeatMapLevels(const std::vector<double>& values) {
  std::vector<unsigned char> levels(values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    const double v = std::isfinite(values[i]) ? std::clamp(values[i], 0.0, 1.0) : 1.0;
    levels[i] = static_cast<unsigned char>(std::lround(v * 255.0));
  }
  return levels;
}

std::vector<unsigned char> HeatMapRgb(const std::vector<double>& values, ColourMap map) {
  const std::array<unsigned char, 256 * 3> palette = HeatMapPalette(map);
  const std::vector<unsigned char> levels = HeatMapLevels(values);
  std::vector<unsigned char> rgb(levels.size() * 3);
  for (size_t i = 0; i < levels.size(); ++i)
    for (int c = 0; c < 3; ++c) rgb[3 * i + c] = palette[3 * levels[i] + c];
  return rgb;
}

std::vector<double> RelativeErrorValues(const ImageRgb& estimate, const ImageRgb& reference) {
  std::vector<double> v(estimate.Size());
  for (size_t i = 0; i < v.size(); ++i) {
    const float e[3] = {estimate.pixels[i].x - reference.pixels[i].x, estimate.pixels[i].y - reference.pixels[i].y,
                        estimate.pixels[i].z - reference.pixels[i].z};
    const float r[3] = {reference.pixels[i].x, reference.pixels[i].y, reference.pixels[i].z};
    v[i] = PixelRelativeError(e, r);
  }
  return v;
}

}  // namespace restir
