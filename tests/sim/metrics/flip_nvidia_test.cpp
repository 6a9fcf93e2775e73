// Issue 16: sim/metrics/flip.h agrees with NVIDIA's reference FLIP implementation (https://github.com/NVlabs/flip)
// to 1e-5 in the mean. tests/data/flip_nvidia/ holds 14 image pairs made by scripts/make_flip_agreement_data.py (LDR
// PNGs: LdrFlip after FlipSrgbToLinear; HDR EXRs: HdrFlip) and what NVIDIA's FLIP, at the commit pairs.json names,
// computed on them: its tool's printed mean, its float error map and, for HDR, its exposures.
//
// What is not covered, because the two differ there on purpose (docs/metrics.md, FLIP): references whose pixels are
// more than half black (NVIDIA's stop exposure is then infinite), a black reference, and negative, NaN or infinite
// values (the project's guards).
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sim/metrics/flip.h"

namespace restir {
namespace {

const std::string kDir = "tests/data/flip_nvidia/";

constexpr double kMeanTolerance = 1e-5;  // issue 16's bound; measured: 8.5e-7 at most
// Per pixel the two differ by float rounding (NVIDIA computes in float throughout, its ppd, filter weights and
// exposures included; we compute those in double and sum in another order), and FLIP amplifies rounding where the
// colour difference is nearly 0: pow(HyAB, 0.7) and pow(colour, 1 - feature) are steepest there. So pixels whose
// FLIP is small can differ by 4e-4 (measured); where FLIP is 0.05 or more they agree to 1.5e-5 (measured).
constexpr double kPixelTolerance = 1e-3;
constexpr double kVisiblePixel = 0.05;
constexpr double kVisiblePixelTolerance = 1e-4;
// NVIDIA's exposures are computed in float (luminance, the tone mapper's inverse, log2), ours in double.
constexpr double kExposureTolerance = 1e-5;

// Reads every channel as floats. PNGs are read as their 8-bit codes and decoded as NVIDIA's tool does: code / 255
// in float, then the sRGB transfer function.
std::vector<float> ReadFloats(const std::string& path, int& width, int& height, int& channels) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) {
    ADD_FAILURE() << path << ": " << OIIO::geterror();
    return {};
  }
  const OIIO::ImageSpec& spec = in->spec();
  width = spec.width;
  height = spec.height;
  channels = spec.nchannels;
  std::vector<float> values(static_cast<size_t>(width) * height * channels);
  if (spec.format == OIIO::TypeDesc::UINT8) {
    std::vector<unsigned char> codes(values.size());
    EXPECT_TRUE(in->read_image(0, 0, 0, channels, OIIO::TypeDesc::UINT8, codes.data())) << path;
    for (size_t i = 0; i < codes.size(); ++i) values[i] = FlipSrgbToLinear(codes[i] / 255.0f);
  } else {
    EXPECT_TRUE(in->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, values.data())) << path;
  }
  return values;
}

ImageRgb ReadRgb(const std::string& path) {
  int w = 0, h = 0, c = 0;
  const std::vector<float> v = ReadFloats(path, w, h, c);
  EXPECT_EQ(c, 3) << path;
  ImageRgb img(w, h);
  if (c != 3) return img;
  for (size_t i = 0; i < img.Size(); ++i) img.pixels[i] = Vec3(v[3 * i], v[3 * i + 1], v[3 * i + 2]);
  return img;
}

struct Pair {
  std::string name, mode, reference, test, nvidiaMap;
  double nvidiaToolMean = 0.0, nvidiaMapMean = 0.0;
  FlipExposureRange nvidiaRange;
};

std::vector<Pair> LoadPairs() {
  std::ifstream f(kDir + "pairs.json");
  const nlohmann::json doc = nlohmann::json::parse(f);
  std::vector<Pair> pairs;
  for (const auto& p : doc.at("pairs")) {
    Pair pair;
    pair.name = p.at("name");
    pair.mode = p.at("mode");
    pair.reference = p.at("reference");
    pair.test = p.at("test");
    pair.nvidiaMap = p.at("nvidia_map");
    pair.nvidiaToolMean = std::stod(p.at("nvidia_tool_mean").get<std::string>());
    pair.nvidiaMapMean = p.at("nvidia_map_mean");
    if (p.contains("nvidia_exposures")) {
      const auto& e = p.at("nvidia_exposures");
      pair.nvidiaRange = {e.at("start"), e.at("stop"), e.at("count")};
    }
    pairs.push_back(pair);
  }
  return pairs;
}

TEST(FlipNvidia, AgreesWithNvidiaFlipToOneInHundredThousandInTheMean) {
  const std::vector<Pair> pairs = LoadPairs();
  ASSERT_EQ(pairs.size(), 14u);
  double worstMean = 0.0, worstPixel = 0.0;
  for (const Pair& p : pairs) {
    SCOPED_TRACE(p.name);
    const ImageRgb reference = ReadRgb(kDir + p.reference), test = ReadRgb(kDir + p.test);
    int w = 0, h = 0, c = 0;
    const std::vector<float> nvidia = ReadFloats(kDir + p.nvidiaMap, w, h, c);
    ASSERT_EQ(c, 1);
    ASSERT_EQ(w, reference.width);
    ASSERT_EQ(h, reference.height);
    FlipExposureRange range;
    const FlipMap ours = p.mode == "ldr" ? LdrFlip(reference, test) : HdrFlip(reference, test, kFlipDefaultPpd, &range);
    ASSERT_EQ(ours.values.size(), nvidia.size());
    if (p.mode == "hdr") {
      EXPECT_EQ(range.count, p.nvidiaRange.count);
      EXPECT_NEAR(range.start, p.nvidiaRange.start, kExposureTolerance);
      EXPECT_NEAR(range.stop, p.nvidiaRange.stop, kExposureTolerance);
    }

    double nvidiaMean = 0.0, maxPixel = 0.0, maxVisiblePixel = 0.0;
    for (size_t i = 0; i < nvidia.size(); ++i) {
      nvidiaMean += nvidia[i];
      const double d = std::fabs(double(ours.values[i]) - double(nvidia[i]));
      maxPixel = std::max(maxPixel, d);
      if (std::max(ours.values[i], nvidia[i]) >= kVisiblePixel) maxVisiblePixel = std::max(maxVisiblePixel, d);
    }
    nvidiaMean /= double(nvidia.size());
    EXPECT_NEAR(nvidiaMean, p.nvidiaMapMean, 1e-12);  // the stored map is the one pairs.json describes
    const double mean = MeanFlip(ours);
    std::printf("%-16s nvidia tool %.6f  nvidia map %.8f  ours %.8f  diff %+.1e  max pixel diff %.1e (%.1e where "
                "FLIP >= %.2f)\n",
                p.name.c_str(), p.nvidiaToolMean, nvidiaMean, mean, mean - nvidiaMean, maxPixel, maxVisiblePixel,
                kVisiblePixel);
    // NVIDIA's tool sums its map in float and prints 6 decimals; the map's mean in double is the sharper check.
    EXPECT_NEAR(mean, nvidiaMean, kMeanTolerance);
    EXPECT_NEAR(mean, p.nvidiaToolMean, kMeanTolerance);
    EXPECT_LE(maxPixel, kPixelTolerance);
    EXPECT_LE(maxVisiblePixel, kVisiblePixelTolerance);
    worstMean = std::max(worstMean, std::fabs(mean - nvidiaMean));
    worstPixel = std::max(worstPixel, maxPixel);
  }
  std::printf("largest mean difference %.1e, largest per-pixel difference %.1e\n", worstMean, worstPixel);
}

}  // namespace
}  // namespace restir
