// sim/assets/texture.h DecodeTexture decodes in a forked child (sim/util/isolation.h): an image that crashes
// OpenImageIO is one InputError, not a dead simulator; and the child decodes an EXR exactly as this process would,
// also after this process started OpenEXR's thread pool (frame writing does), whose threads a forked child does not
// have. DecodeTextures, an asset's images in one child, gives what DecodeTexture gives each, and the same error.
#include <ImfThreading.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "sim/scene/sequence.h"  // InputError
#include "sim/assets/texture.h"
#include "tests/sim/asset_fixtures.h"

namespace restir {
namespace {

namespace fs = std::filesystem;

using test::ReadBytes;

// This process's own decoding of the file, by OpenImageIO's default (C++ OpenEXR) reader on this thread's pools.
std::vector<float> DecodeHere(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  EXPECT_TRUE(in) << OIIO::geterror();
  if (!in) return {};
  const OIIO::ImageSpec spec = in->spec();
  std::vector<float> px(size_t(spec.width) * spec.height * 3);
  EXPECT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, px.data())) << in->geterror();
  return px;
}

TEST(TextureDecode, ExrInTheChildEqualsThisProcessesDecodingAfterOpenExrsPoolStarted) {
  const int before = Imf::globalThreadCount();
  Imf::setGlobalThreadCount(2);  // as SetExrThreads does before frames are written: the pool's threads start now
  const fs::path dir = fs::path(::testing::TempDir()) / "restir-texture-isolation";
  fs::create_directories(dir);
  // Many chunks per image (16 lines per ZIP chunk, 32 per PIZ, tiles), so that a pooled reader would queue work;
  // the lossy ones (B44, DWAA) only agree bit for bit if the child runs the same reader as this process.
  const int w = 97, h = 131;
  std::vector<float> texels(size_t(w) * h * 3);
  for (size_t i = 0; i < texels.size(); ++i) texels[i] = 0.001f * float((i * 7919u) % 5003u) + 1e-4f * float(i % 7);
  for (const char* compression : {"zip", "piz", "b44", "dwaa"})
    for (const bool tiled : {false, true}) {
      const std::string path = (dir / (std::string(compression) + (tiled ? "_tiled" : "") + ".exr")).string();
      {
        auto out = OIIO::ImageOutput::create(path);
        ASSERT_TRUE(out);
        OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::HALF);
        spec.attribute("compression", compression);
        if (tiled) spec.tile_width = spec.tile_height = 32;
        ASSERT_TRUE(out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, texels.data()) && out->close());
      }
      const std::vector<float> here = DecodeHere(path);  // also runs OpenImageIO's EXR set-up in this process
      const Texture t = DecodeTexture(ReadBytes(path), path);
      ASSERT_EQ(t.width, w);
      ASSERT_EQ(t.height, h);
      ASSERT_EQ(t.rgb.size(), here.size());
      EXPECT_EQ(std::memcmp(t.rgb.data(), here.data(), here.size() * sizeof(float)), 0) << path;
      EXPECT_EQ(Imf::globalThreadCount(), 2) << "the pool's size is restored after the child";
    }
  Imf::setGlobalThreadCount(before);
  fs::remove_all(dir);
}

// Found by mutating an IFF file OpenImageIO wrote: its IFF reader corrupts the heap on it and glibc aborts
// (OpenImageIO 2.4, Debian 12). Whatever the decoder does with it, the caller gets one line naming the file.
TEST(TextureDecode, AnImageThatCrashesItsDecoderIsOneInputErrorNamingIt) {
  const std::string path = "tests/data/bad_sequences/decoder_crash.iff";
  const std::string bytes = ReadBytes(path);
  ASSERT_FALSE(bytes.empty()) << path;
  try {
    DecodeTexture(bytes, path);
    FAIL() << "decoded";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path + ": error: ", 0), 0u) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  // The process that asked is unharmed: a good image decodes after it.
  std::vector<float> texels(4 * 2 * 3, 0.25f);
  const fs::path good = fs::path(::testing::TempDir()) / "restir-texture-after-crash.exr";
  auto out = OIIO::ImageOutput::create(good.string());
  ASSERT_TRUE(out);
  const OIIO::ImageSpec spec(4, 2, 3, OIIO::TypeDesc::FLOAT);
  ASSERT_TRUE(out->open(good.string(), spec) && out->write_image(OIIO::TypeDesc::FLOAT, texels.data()) &&
              out->close());
  const Texture t = DecodeTexture(ReadBytes(good.string()), good.string());
  EXPECT_EQ(t.rgb, texels);
  fs::remove(good);
}

// Images of every kind an asset holds (8-bit sRGB PNG and JPEG, 16-bit PNG, float EXR, odd sizes), written by
// OpenImageIO into `dir`; returns their paths.
std::vector<std::string> WriteSampleImages(const fs::path& dir) {
  fs::create_directories(dir);
  std::vector<std::string> paths;
  const struct {
    const char* name;
    int w, h;
    OIIO::TypeDesc type;
  } kinds[] = {{"a.png", 5, 3, OIIO::TypeDesc::UINT8},
               {"b.jpg", 17, 9, OIIO::TypeDesc::UINT8},
               {"c.png", 1, 1, OIIO::TypeDesc::UINT16},
               {"d.exr", 33, 2, OIIO::TypeDesc::FLOAT}};
  for (const auto& k : kinds) {
    std::vector<float> texels(size_t(k.w) * k.h * 3);
    for (size_t i = 0; i < texels.size(); ++i) texels[i] = float((i * 37u) % 101u) / 100.0f;
    const std::string path = (dir / k.name).string();
    auto out = OIIO::ImageOutput::create(path);
    EXPECT_TRUE(out) << path;
    if (!out) continue;
    const OIIO::ImageSpec spec(k.w, k.h, 3, k.type);
    EXPECT_TRUE(out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, texels.data()) && out->close());
    paths.push_back(path);
  }
  return paths;
}

TEST(TextureDecode, ImagesDecodedTogetherEqualEachDecodedAlone) {
  const fs::path dir = fs::path(::testing::TempDir()) / "restir-texture-together";
  const std::vector<std::string> paths = WriteSampleImages(dir);
  ASSERT_EQ(paths.size(), 4u);
  std::vector<std::string> bytes;
  for (const std::string& p : paths) bytes.push_back(ReadBytes(p));
  // Each alone, then all together in two orders (and one image twice), so the result cannot depend on a position.
  for (const std::vector<size_t>& order : {std::vector<size_t>{0, 1, 2, 3}, std::vector<size_t>{3, 1, 0, 2, 3}}) {
    std::vector<EncodedImage> images;
    for (size_t i : order) images.push_back(EncodedImage{&bytes[i], paths[i]});
    const std::vector<Texture> together = DecodeTextures(images);
    ASSERT_EQ(together.size(), order.size());
    for (size_t k = 0; k < order.size(); ++k) {
      const Texture alone = DecodeTexture(bytes[order[k]], paths[order[k]]);
      EXPECT_EQ(together[k].name, alone.name);
      EXPECT_EQ(together[k].width, alone.width) << alone.name;
      EXPECT_EQ(together[k].height, alone.height) << alone.name;
      EXPECT_EQ(together[k].rgb, alone.rgb) << alone.name;
    }
  }
  EXPECT_TRUE(DecodeTextures({}).empty());
  fs::remove_all(dir);
}

// One bad image among good ones: the error names it, whether its decoder refuses it (bytes that are no image) or
// crashes on it (the IFF above), wherever it stands in the list.
TEST(TextureDecode, ImagesDecodedTogetherNameTheOneThatFails) {
  const fs::path dir = fs::path(::testing::TempDir()) / "restir-texture-together-bad";
  const std::vector<std::string> paths = WriteSampleImages(dir);
  ASSERT_EQ(paths.size(), 4u);
  const std::string good0 = ReadBytes(paths[0]), good3 = ReadBytes(paths[3]);
  const std::string crash = ReadBytes("tests/data/bad_sequences/decoder_crash.iff");
  ASSERT_FALSE(crash.empty());
  const std::string noImage = "these bytes are no image file";
  for (const bool crashes : {false, true})
    for (size_t at = 0; at < 3; ++at) {
      const std::string badName = crashes ? "bad/crashes.iff" : "bad/no_image.png";
      std::vector<EncodedImage> images = {{&good0, paths[0]}, {&good3, paths[3]}};
      images.insert(images.begin() + std::ptrdiff_t(at), EncodedImage{crashes ? &crash : &noImage, badName});
      try {
        DecodeTextures(images);
        FAIL() << badName << " decoded";
      } catch (const InputError& e) {
        const std::string message = e.what();
        EXPECT_EQ(message.rfind(badName + ": error: ", 0), 0u) << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
      }
    }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace restir
