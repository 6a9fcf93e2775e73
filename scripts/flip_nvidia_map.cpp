// Writes NVIDIA FLIP's per-pixel error map as a float EXR, for tests/data/flip_nvidia/. NVIDIA's command-line tool
// prints the mean to 6 decimals and saves its map only as an 8-bit PNG; this driver runs the same steps as the tool
// (FLIPToolHelpers.h: load with its ImageHelpers, sRGB decode of PNGs, FLIP::evaluate with the default parameters)
// and keeps the map's floats. Not part of the build: it compiles against a checkout of https://github.com/NVlabs/flip
// (scripts/make_flip_agreement_data.py says how), which this repository does not contain.
//
// Usage: flip_nvidia_map REFERENCE TEST OUT.exr
// Prints: mean (float sum in row order, as the tool's pooling) mean (double), start/stop exposures and count (HDR),
// and writes OUT.exr (one FLOAT channel "Y", ZIP) and OUT.png (the tool's grayscale PNG of the map, for comparing
// with the tool's own `-nm` output).
#include <cstdio>
#include <string>
#include <vector>

#include "FLIP.h"
#include "tool/imagehelpers.h"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s REFERENCE TEST OUT.exr\n", argv[0]);
    return 2;
  }
  const std::string refName = argv[1], testName = argv[2], outName = argv[3];
  const bool hdr = refName.size() > 4 && refName.substr(refName.size() - 4) == ".exr";
  FLIP::image<FLIP::color3> reference, test;
  if (!ImageHelpers::load(reference, refName) || !ImageHelpers::load(test, testName)) return 1;
  if (!hdr) {
    reference.sRGBToLinearRGB();
    test.sRGBToLinearRGB();
  }
  FLIP::Parameters parameters;
  FLIP::image<float> map(reference.getWidth(), reference.getHeight(), 0.0f);
  FLIP::image<float> exposureMap(reference.getWidth(), reference.getHeight());
  FLIP::evaluate(reference, test, hdr, parameters, map, exposureMap);

  const int w = map.getWidth(), h = map.getHeight();
  std::vector<float> values(static_cast<size_t>(w) * h);
  float floatSum = 0.0f;
  double doubleSum = 0.0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float v = map.get(x, y);
      values[static_cast<size_t>(y) * w + x] = v;
      floatSum += v;
      doubleSum += v;
    }
  std::printf("mean_float %.9g\nmean_double %.17g\n", floatSum / float(size_t(w) * h), doubleSum / (double(w) * h));
  if (hdr)
    std::printf("start %.9g\nstop %.9g\ncount %d\n", parameters.startExposure, parameters.stopExposure,
                parameters.numExposures);

  EXRHeader header;
  InitEXRHeader(&header);
  EXRChannelInfo channel{};
  channel.name[0] = 'Y';
  int pixelType = TINYEXR_PIXELTYPE_FLOAT;
  header.num_channels = 1;
  header.channels = &channel;
  header.pixel_types = &pixelType;
  header.requested_pixel_types = &pixelType;
  header.compression_type = TINYEXR_COMPRESSIONTYPE_ZIP;
  EXRImage image;
  InitEXRImage(&image);
  float* planes[1] = {values.data()};
  image.num_channels = 1;
  image.images = reinterpret_cast<unsigned char**>(planes);
  image.width = w;
  image.height = h;
  const char* err = nullptr;
  if (SaveEXRImageToFile(&image, &header, outName.c_str(), &err) != TINYEXR_SUCCESS) {
    std::fprintf(stderr, "%s: %s\n", outName.c_str(), err ? err : "write failed");
    return 1;
  }
  FLIP::image<FLIP::color3> gray(w, h);
  gray.copyFloatToColor3(map);
  return ImageHelpers::pngSave(outName.substr(0, outName.size() - 4) + ".png", gray) ? 0 : 1;
}
