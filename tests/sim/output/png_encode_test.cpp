// The scrubber's PNGs decode, with another decoder than the encoder's (OpenImageIO's), to the pixels given: palette,
// grey and RGB, over sizes from one pixel to wider than tall and odd.
#include "sim/output/png_encode.h"

#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <filesystem>
#include <fstream>
#include <random>

namespace restir {
namespace {

std::vector<unsigned char> Decode(const std::string& png, int w, int h, int& channels) {
  const std::string path = ::testing::TempDir() + "/restir-png-encode.png";
  std::ofstream(path, std::ios::binary | std::ios::trunc) << png;
  auto in = OIIO::ImageInput::open(path);
  EXPECT_TRUE(in) << OIIO::geterror();
  if (!in) return {};
  EXPECT_EQ(in->spec().width, w);
  EXPECT_EQ(in->spec().height, h);
  channels = in->spec().nchannels;
  std::vector<unsigned char> px(static_cast<size_t>(w) * h * channels);
  EXPECT_TRUE(in->read_image(0, 0, 0, channels, OIIO::TypeDesc::UINT8, px.data()));
  return px;
}

TEST(PngEncode, EveryKindDecodesToItsPixelsAtEverySize) {
  std::mt19937 rng(7);
  std::array<unsigned char, 256 * 3> palette;
  for (unsigned char& c : palette) c = static_cast<unsigned char>(rng());
  for (auto [w, h] : {std::pair{1, 1}, {3, 1}, {1, 5}, {17, 9}, {640, 3}, {64, 36}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    std::vector<unsigned char> one(static_cast<size_t>(w) * h), rgb(one.size() * 3);
    for (unsigned char& v : one) v = static_cast<unsigned char>(rng() % 7 == 0 ? rng() : 3);  // runs and noise
    for (unsigned char& v : rgb) v = static_cast<unsigned char>(rng());
    int channels = 0;
    const std::vector<unsigned char> indexed = Decode(EncodeIndexedPng(one, w, h, palette), w, h, channels);
    ASSERT_EQ(channels, 3);
    for (size_t i = 0; i < one.size(); ++i)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(indexed[3 * i + c], palette[3 * one[i] + c]) << i;
    EXPECT_EQ(Decode(EncodeGreyPng(one, w, h), w, h, channels), one);
    EXPECT_EQ(channels, 1);
    EXPECT_EQ(Decode(EncodeRgbPng(rgb, w, h), w, h, channels), rgb);
    EXPECT_EQ(channels, 3);
  }
}

// A PNG cut anywhere, or with a byte of a chunk length changed, is not whole; every PNG written here is.
TEST(PngIsWhole, EveryCutAndEveryBrokenLengthFails) {
  std::array<unsigned char, 256 * 3> palette{};
  const std::string png = EncodeIndexedPng(std::vector<unsigned char>(24 * 5, 7), 24, 5, palette);
  ASSERT_TRUE(PngIsWhole(png));
  for (size_t n = 0; n < png.size(); ++n) EXPECT_FALSE(PngIsWhole(png.substr(0, n))) << n;
  EXPECT_FALSE(PngIsWhole(png + "x"));
  std::string longer = png;
  longer[8 + 3] = static_cast<char>(longer[8 + 3] + 1);  // IHDR's length
  EXPECT_FALSE(PngIsWhole(longer));
  EXPECT_TRUE(PngIsWhole(EncodeRgbPng(std::vector<unsigned char>(3 * 7 * 3, 1), 7, 3)));
  EXPECT_TRUE(PngIsWhole(EncodeGreyPng(std::vector<unsigned char>(1, 0), 1, 1)));
}

TEST(PngEncode, APixelCountOtherThanTheSizeIsRefused) {
  std::array<unsigned char, 256 * 3> palette{};
  EXPECT_THROW(EncodeGreyPng(std::vector<unsigned char>(5), 2, 2), std::runtime_error);
  EXPECT_THROW(EncodeIndexedPng(std::vector<unsigned char>(4), 4, 2, palette), std::runtime_error);
  EXPECT_THROW(EncodeRgbPng(std::vector<unsigned char>(4), 2, 2), std::runtime_error);
  EXPECT_THROW(EncodeGreyPng({}, 0, 0), std::runtime_error);
}

}  // namespace
}  // namespace restir
