#include "sim/assets/texture.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <ImfThreading.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "sim/util/isolation.h"
#include "sim/util/input_error.h"
#include "sim/assets/texture_decode.h"
#include "sim/util/text.h"

namespace restir {

namespace {

constexpr int kMaxTextureSide = 16384;
constexpr int64_t kMaxTextureTexels = int64_t(1) << 26;

int64_t Wrap(int64_t i, int64_t n, TextureWrap mode) {
  switch (mode) {
    case TextureWrap::kClampToEdge:
      return std::clamp<int64_t>(i, 0, n - 1);
    case TextureWrap::kMirroredRepeat: {
      int64_t r = i % (2 * n);
      if (r < 0) r += 2 * n;
      return r < n ? r : 2 * n - 1 - r;
    }
    case TextureWrap::kRepeat:
      break;
  }
  const int64_t r = i % n;
  return r < 0 ? r + n : r;
}

// A coordinate's equivalent in a bounded range, taken in double before the texel indices are formed, so that huge
// coordinates keep their fraction and the indices fit: its fraction (repeat: period 1), its value modulo 2 (a
// mirrored repeat's period), or the value clamped to [-1, 2], beyond which every tap lands on the edge anyway.
double Reduce(float c, TextureWrap mode) {
  const double d = c;
  switch (mode) {
    case TextureWrap::kClampToEdge:
      return std::clamp(d, -1.0, 2.0);
    case TextureWrap::kMirroredRepeat:
      return d - 2.0 * std::floor(d / 2.0);
    case TextureWrap::kRepeat:
      break;
  }
  return d - std::floor(d);
}

}  // namespace

Vec3 Texture::Texel(int64_t x, int64_t y) const {
  const size_t i = 3 * (static_cast<size_t>(Wrap(y, height, wrapV)) * static_cast<size_t>(width) +
                        static_cast<size_t>(Wrap(x, width, wrapU)));
  return Vec3(rgb[i], rgb[i + 1], rgb[i + 2]);
}

Vec3 SampleBilinear(const Texture& t, float u, float v) {
  if (t.width <= 0 || t.height <= 0) return Vec3(1.0f);
  // Non-finite coordinates (a broken asset's UVs) read the first texel rather than index with garbage.
  if (!std::isfinite(u) || !std::isfinite(v)) return t.Texel(0, 0);
  const double fu = Reduce(u, t.wrapU);
  const double fv = Reduce(v, t.wrapV);
  const double x = fu * t.width - 0.5;
  const double y = (1.0 - fv) * t.height - 0.5;
  const double x0 = std::floor(x), y0 = std::floor(y);
  const float ax = static_cast<float>(x - x0), ay = static_cast<float>(y - y0);
  const int64_t ix = static_cast<int64_t>(x0), iy = static_cast<int64_t>(y0);
  const Vec3 top = t.Texel(ix, iy) * (1.0f - ax) + t.Texel(ix + 1, iy) * ax;
  const Vec3 bottom = t.Texel(ix, iy + 1) * (1.0f - ax) + t.Texel(ix + 1, iy + 1) * ax;
  return top * (1.0f - ay) + bottom * ay;
}

Vec3 MeanOverTriangle(const Texture& t, const Vec2& uv0, const Vec2& uv1, const Vec2& uv2) {
  auto texels = [&](const Vec2& a, const Vec2& b) {
    const double du = (double(b.x) - a.x) * t.width, dv = (double(b.y) - a.y) * t.height;
    return std::sqrt(du * du + dv * dv);
  };
  const double edge = std::max({texels(uv0, uv1), texels(uv1, uv2), texels(uv2, uv0)});
  const int n = std::isfinite(edge) ? static_cast<int>(std::clamp(std::ceil(edge), 1.0, 64.0)) : 1;
  // Sub-triangles of the n x n subdivision: for cell (i, j), the upright one (i + j < n) and, where it exists,
  // the inverted one; their centroids in barycentric coordinates (b1, b2) along uv1 - uv0 and uv2 - uv0.
  const Vec2 e1 = uv1 - uv0, e2 = uv2 - uv0;
  glm::dvec3 sum(0.0);
  size_t count = 0;
  const double inv = 1.0 / n;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; i + j < n; ++j) {
      for (int inverted = 0; inverted < 2; ++inverted) {
        if (inverted && i + j + 1 >= n) break;
        const double b1 = (i + (inverted ? 2.0 : 1.0) / 3.0) * inv;
        const double b2 = (j + (inverted ? 2.0 : 1.0) / 3.0) * inv;
        const Vec2 uv = uv0 + static_cast<float>(b1) * e1 + static_cast<float>(b2) * e2;
        sum += glm::dvec3(SampleBilinear(t, uv.x, uv.y));
        ++count;
      }
    }
  }
  return Vec3(sum / double(count));
}

float SrgbToLinear(float c) {
  if (!(c > 0.0f)) return 0.0f;
  if (c >= 1.0f) return 1.0f;
  return c <= 0.04045f ? c / 12.92f : static_cast<float>(std::pow((double(c) + 0.055) / 1.055, 2.4));
}

namespace {

// libpng and libjpeg print their own diagnostics on stderr while OpenImageIO decodes; a bad texture must give one
// message, so stderr goes to a temporary file for the duration and what it caught is folded into the error.
class StderrCapture {
 public:
  StderrCapture() {
    std::fflush(stderr);
    file_ = std::tmpfile();
    saved_ = file_ ? ::dup(2) : -1;
    if (saved_ >= 0) ::dup2(::fileno(file_), 2);
  }
  ~StderrCapture() { Restore(); }
  // Restores stderr; returns the first line written while captured.
  std::string Restore() {
    std::string first;
    if (saved_ >= 0) {
      std::fflush(stderr);
      ::dup2(saved_, 2);
      ::close(saved_);
      saved_ = -1;
      std::rewind(file_);
      char line[256];
      if (std::fgets(line, sizeof(line), file_)) first = line;
      while (!first.empty() && (first.back() == '\n' || first.back() == '\r')) first.pop_back();
    }
    if (file_) std::fclose(file_), file_ = nullptr;
    return first;
  }

 private:
  std::FILE* file_ = nullptr;
  int saved_ = -1;
};

// TryDecodeLinearImage's work, in the calling process; it runs in a forked child (sim/util/isolation.h).
bool DecodeLinearImageHere(const std::string& bytes, const std::string& name, Texture& t, std::string& problem) {
  StderrCapture capture;
  auto fail = [&](const std::string& what) {
    const std::string said = capture.Restore();
    problem = OneLine(what + (said.empty() ? "" : " [" + said + "]"));
    t = Texture{};
    return false;
  };
  OIIO::Filesystem::IOMemReader mem(const_cast<char*>(bytes.data()), bytes.size());
  auto in = OIIO::ImageInput::open(name, nullptr, &mem);
  if (!in) {
    const std::string why = OIIO::geterror();
    return fail("not an image OpenImageIO can read" + (why.empty() ? std::string() : " (" + why + ")"));
  }
  in->threads(1);  // OpenImageIO's pool, if the parent started it, has no threads in this child
  const OIIO::ImageSpec spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.depth != 1 || spec.nchannels <= 0)
    return fail("the image has no pixels");
  // The header alone decides the allocation, so it is bounded before anything is allocated: 16384 on a side and
  // 2^26 texels (a 8192 x 8192 texture is 768 MiB as linear float RGB).
  if (spec.width > kMaxTextureSide || spec.height > kMaxTextureSide ||
      int64_t(spec.width) * spec.height > kMaxTextureTexels)
    return fail("the image is " + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
                " texels, more than the limit of 16384 on a side and 67,108,864 in all");
  const int channels = std::min(spec.nchannels, 3);
  const size_t texels = static_cast<size_t>(spec.width) * spec.height;
  t = Texture{};
  t.name = name;
  t.width = spec.width;
  t.height = spec.height;
  // Decoded straight into the texture when it has three channels (one buffer, converted in place).
  std::vector<float> narrow;
  std::vector<float>& pixels = channels == 3 ? t.rgb : narrow;
  pixels.resize(texels * channels);
  if (!in->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, pixels.data()))
    return fail("cannot decode the image (" + in->geterror() + ")");
  const bool srgb = spec.format.basetype == OIIO::TypeDesc::UINT8 || spec.format.basetype == OIIO::TypeDesc::UINT16 ||
                    spec.format.basetype == OIIO::TypeDesc::INT8 || spec.format.basetype == OIIO::TypeDesc::INT16;
  if (channels != 3) {
    t.rgb.resize(texels * 3);
    for (size_t p = 0; p < texels; ++p)
      for (int c = 0; c < 3; ++c) t.rgb[3 * p + c] = narrow[p * channels + std::min(c, channels - 1)];
    std::vector<float>().swap(narrow);
  }
  if (srgb)
    for (float& v : t.rgb) v = SrgbToLinear(v);
  capture.Restore();  // a decoder's warnings on an image it did decode are not ours to print
  return true;
}

// OpenEXR's global pool (frame_writer.h SetExrThreads; OpenImageIO sizes it too) has its worker threads in this
// process only: a forked child decoding an EXR through it would queue its chunks for threads it does not have and
// wait forever. Emptied while a child runs, so that the child's decoder finds no pool and works on its own thread;
// then restored (the threads are started again). A frame written meanwhile compresses on its calling thread.
class ExrPoolPaused {
 public:
  ExrPoolPaused() : threads_(Imf::globalThreadCount()) {
    if (threads_ > 0) Imf::setGlobalThreadCount(0);
  }
  ~ExrPoolPaused() {
    if (threads_ > 0) Imf::setGlobalThreadCount(threads_);
  }
  ExrPoolPaused(const ExrPoolPaused&) = delete;
  ExrPoolPaused& operator=(const ExrPoolPaused&) = delete;

 private:
  int threads_;
};

// The decoded image as the child sends it: width and height (int32), then the texels' floats.
void AppendDecoded(const Texture& t, std::string& out) {
  const int32_t size[2] = {t.width, t.height};
  out.append(reinterpret_cast<const char*>(size), sizeof(size));
  out.append(reinterpret_cast<const char*>(t.rgb.data()), t.rgb.size() * sizeof(float));
}

// The parent's reading of one AppendDecoded from `bytes` at `at`, which it advances: false where the bytes do not
// hold a whole image within the limits.
bool ReadDecoded(const std::string& bytes, size_t& at, Texture& t) {
  int32_t size[2];
  if (bytes.size() - at < sizeof(size)) return false;
  std::memcpy(size, bytes.data() + at, sizeof(size));
  if (size[0] <= 0 || size[1] <= 0 || size[0] > kMaxTextureSide || size[1] > kMaxTextureSide ||
      int64_t(size[0]) * size[1] > kMaxTextureTexels)
    return false;
  const size_t floats = size_t(size[0]) * size_t(size[1]) * 3;
  if (bytes.size() - at - sizeof(size) < floats * sizeof(float)) return false;
  t.width = size[0];
  t.height = size[1];
  t.rgb.resize(floats);
  std::memcpy(t.rgb.data(), bytes.data() + at + sizeof(size), floats * sizeof(float));
  at += sizeof(size) + floats * sizeof(float);
  return true;
}

// Decoded textures hold no negative or non-finite texel (HDR files may hold NaN or negative ones).
void ClampTexels(Texture& t) {
  for (float& v : t.rgb)
    if (!std::isfinite(v) || v < 0.0f) v = 0.0f;
}

// What one child made of a list of images: all of them decoded (texels as the files hold them), or the problem and
// which image the decoder refused (`refused` < the list's size), or the problem alone where the child crashed, hung,
// ran out of memory or sent a damaged result.
struct ChildDecoding {
  std::vector<Texture> textures;  // one per image, when every one decoded
  std::string problem;            // one line, without the image's name
  size_t refused = SIZE_MAX;      // the image the decoder refused
};

// Every image in one forked child (sim/util/isolation.h): a fork costs more than decoding a small texture, and an
// asset may hold dozens. The child sends each AppendDecoded in turn, or "<index> <problem>" for the one it refused.
ChildDecoding DecodeInOneChild(const std::vector<EncodedImage>& images) {
  const auto work = [&](std::string& out) {
    std::string all;
    for (size_t i = 0; i < images.size(); ++i) {
      Texture decoded;
      std::string problem;
      if (!DecodeLinearImageHere(*images[i].bytes, images[i].name, decoded, problem)) {
        out = std::to_string(i) + " " + problem;
        return false;
      }
      AppendDecoded(decoded, all);
    }
    out = std::move(all);
    return true;
  };
  IsolatedResult r;
  {
    const ExrPoolPaused paused;
    r = RunIsolated(work, IsolatedTool{"the image decoder", "OpenImageIO"}, IsolationLimits{});
  }
  ChildDecoding d;
  if (r.status == IsolatedResult::Status::kRefused) {
    const size_t space = r.bytes.find(' ');
    const std::string index = r.bytes.substr(0, space);
    if (space != std::string::npos && !index.empty() && index.size() < 10 &&
        index.find_first_not_of("0123456789") == std::string::npos && std::stoul(index) < images.size()) {
      d.refused = std::stoul(index);
      d.problem = r.bytes.substr(space + 1);
      return d;
    }
    d.problem = "the image decoder sent a damaged result";  // a refusal without its image's index
    return d;
  }
  if (r.status != IsolatedResult::Status::kDone) {
    d.problem = r.bytes;
    return d;
  }
  std::vector<Texture> textures(images.size());
  size_t at = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    if (!ReadDecoded(r.bytes, at, textures[i])) break;
    textures[i].name = images[i].name;
    if (i + 1 == images.size() && at == r.bytes.size()) {
      d.textures = std::move(textures);
      return d;
    }
  }
  d.problem = "the image decoder sent a damaged result";
  return d;
}

}  // namespace

bool TryDecodeLinearImage(const std::string& bytes, const std::string& name, Texture& t, std::string& problem) {
  ChildDecoding d = DecodeInOneChild({EncodedImage{&bytes, name}});
  const bool decoded = !d.textures.empty();
  t = decoded ? std::move(d.textures[0]) : Texture{};
  problem = std::move(d.problem);
  return decoded;
}

Texture DecodeTexture(const std::string& bytes, const std::string& name) {
  return std::move(DecodeTextures({EncodedImage{&bytes, name}})[0]);
}

std::vector<Texture> DecodeTextures(const std::vector<EncodedImage>& images) {
  if (images.empty()) return {};
  ChildDecoding d = DecodeInOneChild(images);
  if (d.refused < images.size()) throw InputError(OneLine(images[d.refused].name + ": error: " + d.problem));
  if (d.textures.empty() && images.size() == 1) throw InputError(OneLine(images[0].name + ": error: " + d.problem));
  if (d.textures.empty()) {
    // The child crashed, hung, ran out of memory (it held them all) or sent less than it should: a child per image
    // names the one that fails alone, or decodes them all.
    for (const EncodedImage& image : images) d.textures.push_back(DecodeTexture(*image.bytes, image.name));
    return d.textures;
  }
  for (Texture& t : d.textures) ClampTexels(t);
  return d.textures;
}

}  // namespace restir
