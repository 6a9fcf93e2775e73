#include "sim/output/frame_writer.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfIO.h>
#include <ImfThreading.h>
#include <ImfStringAttribute.h>
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include "sim/util/atomic_file.h"

namespace restir {

namespace {

void AddRgbLayer(Imf::Header& header, Imf::FrameBuffer& fb, const std::string& prefix, const ImageRgb& img) {
  const char* names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c) {
    const std::string name = prefix.empty() ? names[c] : prefix + "." + names[c];
    header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    char* base = reinterpret_cast<char*>(const_cast<Vec3*>(img.pixels.data())) + c * sizeof(float);
    fb.insert(name, Imf::Slice(Imf::FLOAT, base, sizeof(Vec3), sizeof(Vec3) * img.width));
  }
}

void AddScalarLayer(Imf::Header& header, Imf::FrameBuffer& fb, const std::string& name,
                    const std::vector<float>& values, int width) {
  header.channels().insert(name, Imf::Channel(Imf::FLOAT));
  fb.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(values.data())),
                             sizeof(float), sizeof(float) * width));
}

// An OpenEXR output stream into one string reserved for the whole file: Imf::StdOSStream's ostringstream grows by
// doubling (each step a copy into fresh pages) and str() copies the file once more; on README command 1 those
// copies and their page faults were most of the EXRs' cost after the run-length coding itself. Seeks (the offset
// table is written last) overwrite in place.
class StringOStream final : public Imf::OStream {
 public:
  explicit StringOStream(size_t reserve) : Imf::OStream("memory") { bytes_.reserve(reserve); }
  void write(const char c[], int n) override {
    const size_t count = static_cast<size_t>(n);
    const size_t inside = pos_ < bytes_.size() ? std::min(count, bytes_.size() - pos_) : 0;
    if (pos_ > bytes_.size()) bytes_.resize(pos_, '\0');
    bytes_.replace(pos_, inside, c, inside);
    bytes_.append(c + inside, count - inside);
    pos_ += count;
  }
  uint64_t tellp() override { return pos_; }
  void seekp(uint64_t pos) override { pos_ = static_cast<size_t>(pos); }
  const std::string& Bytes() const { return bytes_; }

 private:
  std::string bytes_;
  size_t pos_ = 0;
};

float SrgbEncode(float v) {
  v = std::clamp(v, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

// The preview byte by its definition: sRGB-encoded, scaled to 255 and rounded; non-finite values black.
int DefinedPreviewByte(float v) {
  return static_cast<int>(std::lround(255.0f * SrgbEncode(std::isfinite(v) ? v : 0.0f)));
}

// Where the preview byte steps: threshold[b] is the least float in [0, 1] whose byte is b or more (b = 1..255), so
// a value's byte is the number of thresholds at or below it. Found by bisection over the floats' bit patterns,
// which order non-negative floats as numbers; that counting equals the definition wherever the definition never
// steps back down, which tests/sim/output/frame_writer_test.cpp checks around every threshold (and a sweep of all
// 1.07e9 floats of [0, 1] did once). To count without a search, `first` holds the byte at the start of each bucket of
// floats sharing their top 16 bits (exponent and 7 mantissa bits): a bucket spans less than 1% of its values, over
// which the byte rises by at most 0.9 (its steepest is 255 · 1.055 / 2.4 = 112 per unit of ln v, at v = 1; the
// constructor checks it), so one comparison finishes it. One powf and one lroundf per channel cost README command 1
// about 1% of its CPU.
struct PreviewByteTable {
  static constexpr int kShift = 16;
  static constexpr uint32_t kBuckets = (0x3F800000u >> kShift) + 1;  // through the bucket of 1.0f
  float threshold[257] = {};  // [256]: +inf, so a bucket at byte 255 never steps
  uint8_t first[kBuckets] = {};
  PreviewByteTable() {
    const uint32_t one = std::bit_cast<uint32_t>(1.0f);
    for (int b = 1; b < 256; ++b) {
      uint32_t lo = 0, hi = one;  // DefinedPreviewByte(1) = 255 >= b
      while (lo < hi) {
        const uint32_t mid = lo + (hi - lo) / 2;
        if (DefinedPreviewByte(std::bit_cast<float>(mid)) >= b) hi = mid;
        else lo = mid + 1;
      }
      threshold[b] = std::bit_cast<float>(lo);
    }
    threshold[256] = std::numeric_limits<float>::infinity();
    int b = 0;
    for (uint32_t k = 0; k < kBuckets; ++k) {
      const float start = std::bit_cast<float>(k << kShift), last = std::bit_cast<float>(((k + 1) << kShift) - 1);
      while (b < 255 && start >= threshold[b + 1]) ++b;
      first[k] = static_cast<uint8_t>(b);
      if (b < 254 && last >= threshold[b + 2]) throw std::logic_error("a preview bucket spans two byte steps");
    }
  }
};

const PreviewByteTable& PreviewTable() {
  static const PreviewByteTable table;
  return table;
}

unsigned char TablePreviewByte(const PreviewByteTable& t, float linear) {
  if (!(linear > 0.0f) || !std::isfinite(linear)) return 0;  // negative, zero, NaN and infinities
  if (linear >= 1.0f) return 255;
  const int b = t.first[std::bit_cast<uint32_t>(linear) >> PreviewByteTable::kShift];
  return static_cast<unsigned char>(b + (linear >= t.threshold[b + 1] ? 1 : 0));
}

}  // namespace

unsigned char PreviewByte(float linear) { return TablePreviewByte(PreviewTable(), linear); }

void SetExrThreads(int threads) { Imf::setGlobalThreadCount(std::max(0, threads)); }

const char* ExrCompressionName(ExrCompression c) {
  switch (c) {
    case ExrCompression::kNone: return "none";
    case ExrCompression::kRle: return "rle";
    case ExrCompression::kZip: return "zip";
  }
  return "none";
}

std::optional<ExrCompression> ParseExrCompression(const std::string& name) {
  for (ExrCompression c : {ExrCompression::kNone, ExrCompression::kRle, ExrCompression::kZip})
    if (name == ExrCompressionName(c)) return c;
  return std::nullopt;
}

void WriteFrameExr(const std::string& path, const FrameLayers& layers, ExrCompression compression) {
  const ImageRgb& est = *layers.estimate;
  const int w = est.width, h = est.height;
  const GBuffer& g = *layers.gbuffer;
  Imf::Header header(w, h);
  // Stored by default: noisy float radiance barely compresses (run-length keeps 63% of the bytes, zip at level 1
  // 56%, both mostly by the flat G-buffer, background and flag channels), and on README command 1 OpenEXR's
  // run-length coding was 5% of the run's CPU (issue 16: the run must fit in five minutes), zip more.
  header.compression() = compression == ExrCompression::kRle   ? Imf::RLE_COMPRESSION
                         : compression == ExrCompression::kZip ? Imf::ZIP_COMPRESSION
                                                               : Imf::NO_COMPRESSION;
  if (!layers.sequenceHash.empty()) header.insert("restir:sequenceHash", Imf::StringAttribute(layers.sequenceHash));
  Imf::FrameBuffer fb;
  AddRgbLayer(header, fb, "", est);
  ImageRgb error;
  if (layers.reference) {
    AddRgbLayer(header, fb, "reference", *layers.reference);
    if (layers.referenceStdError) AddRgbLayer(header, fb, "reference_stderr", *layers.referenceStdError);
    error = ImageRgb(w, h);
    for (size_t i = 0; i < est.Size(); ++i) error.pixels[i] = est.pixels[i] - layers.reference->pixels[i];
    AddRgbLayer(header, fb, "error", error);
  }
  std::vector<float> disocc(g.Size()), nx(g.Size()), ny(g.Size()), nz(g.Size());
  for (size_t i = 0; i < g.Size(); ++i) {
    disocc[i] = g.disoccluded[i] ? 1.0f : 0.0f;
    nx[i] = g.nsX[i], ny[i] = g.nsY[i], nz[i] = g.nsZ[i];
  }
  AddScalarLayer(header, fb, "disocclusion.Y", disocc, w);
  AddScalarLayer(header, fb, "depth.Z", g.depth, w);
  AddScalarLayer(header, fb, "normal.X", nx, w);
  AddScalarLayer(header, fb, "normal.Y", ny, w);
  AddScalarLayer(header, fb, "normal.Z", nz, w);
  if (layers.flip) {
    if (layers.flip->size() != est.Size()) throw std::invalid_argument("flip layer size differs from the image");
    AddScalarLayer(header, fb, "flip.Y", *layers.flip, w);
  }
  if (layers.ensembleBias) AddRgbLayer(header, fb, "bias", *layers.ensembleBias);
  if (layers.ensembleVariance) AddRgbLayer(header, fb, "variance", *layers.ensembleVariance);
  // Encoded in memory, so the bytes reach the file through WriteFileAtomic's checked writes. Reserved for the whole
  // file, so the string never grows: OpenEXR stores a chunk raw where its compression would not be smaller (a
  // 640x360 file of 18 channels of uniform noise: the raw floats plus 6,760 bytes), so the file is at most the
  // raw channels, 16 bytes a scanline (its offset and its chunk's header) and the header.
  size_t channels = 0;
  for (auto it = header.channels().begin(); it != header.channels().end(); ++it) ++channels;
  StringOStream stream(channels * est.Size() * sizeof(float) + size_t{16} * static_cast<size_t>(h) +
                       (size_t{64} << 10));
  {
    // Chunks are compressed independently; OpenEXR's own pool (SetExrThreads) compresses them in parallel, with
    // the same bytes whatever the thread count.
    Imf::OutputFile file(stream, header, Imf::globalThreadCount());
    file.setFrameBuffer(fb);
    file.writePixels(h);
  }
  WriteFileAtomic(path, stream.Bytes());
}

std::string FrameNumber(int frame) {
  char buf[16];
  std::snprintf(buf, sizeof(buf), "%04d", frame);
  return buf;
}

std::string EncodePng(const std::vector<unsigned char>& rgb, int w, int h, bool srgb) {
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  auto out = OIIO::ImageOutput::create("png");
  if (!out) throw std::runtime_error(std::string("no PNG encoder: ") + OIIO::geterror());
  OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::UINT8);
  if (srgb) spec.attribute("oiio:ColorSpace", "sRGB");
  // Stored, not deflated: on a 1280x360 preview of noisy renders zlib's fastest level took 27 ms and kept 58% of the
  // bytes, storing takes 3 ms (README command 1: 576 previews, 14 s of CPU for 330 MB of disk).
  spec.attribute("png:compressionLevel", 0);
  // No row filter (PNG_FILTER_NONE): on noisy tone-mapped renders libpng's adaptive choice among the five filters
  // cost more than it saved (README command 1's 8-frame prefix: 1.5 s of CPU, and the files 3% larger with it).
  spec.attribute("png:filter", 0x08);
  if (!out->set_ioproxy(&proxy) || !out->open("memory.png", spec) ||
      !out->write_image(OIIO::TypeDesc::UINT8, rgb.data()) || !out->close())
    throw std::runtime_error("cannot encode a PNG: " + out->geterror());
  return std::string(bytes.begin(), bytes.end());
}

float PreviewExposure(const ImageRgb& exposureSource) {
  std::vector<float> lum;
  lum.reserve(exposureSource.Size());
  for (const Vec3& p : exposureSource.pixels) {
    const float y = Luminance(p);
    if (y > 0.0f && std::isfinite(y)) lum.push_back(y);
  }
  float exposure = 1.0f;
  if (!lum.empty()) {
    const size_t k = std::min(lum.size() - 1, static_cast<size_t>(0.9 * double(lum.size())));
    std::nth_element(lum.begin(), lum.begin() + static_cast<std::ptrdiff_t>(k), lum.end());
    if (lum[k] > 0.0f) exposure = 0.8f / lum[k];
  }
  return exposure;
}

std::vector<unsigned char> TonemapPreview(const ImageRgb& img, float exposure) {
  std::vector<unsigned char> rgb(img.Size() * 3);
  const PreviewByteTable& table = PreviewTable();
  for (size_t i = 0; i < img.Size(); ++i) {
    const Vec3 v = img.pixels[i] * exposure;
    for (int c = 0; c < 3; ++c) rgb[i * 3 + c] = TablePreviewByte(table, v[c]);
  }
  return rgb;
}

void WritePreviewPng(const std::string& path, const std::vector<const std::vector<unsigned char>*>& panels, int w,
                     int h) {
  const size_t rowBytes = static_cast<size_t>(w) * 3, outRow = rowBytes * panels.size();
  std::vector<unsigned char> rgb(outRow * static_cast<size_t>(h));
  for (size_t p = 0; p < panels.size(); ++p) {
    if (panels[p]->size() != rowBytes * static_cast<size_t>(h))
      throw std::invalid_argument("preview panel size differs from the image");
    for (int y = 0; y < h; ++y)
      std::copy_n(panels[p]->data() + rowBytes * static_cast<size_t>(y), rowBytes,
                  rgb.data() + outRow * static_cast<size_t>(y) + rowBytes * p);
  }
  WriteFileAtomic(path, EncodePng(rgb, w * static_cast<int>(panels.size()), h, true));
}

void WritePreviewPng(const std::string& path, const ImageRgb& estimate, const ImageRgb* reference) {
  const float exposure = PreviewExposure(reference ? *reference : estimate);
  const std::vector<unsigned char> left = TonemapPreview(estimate, exposure);
  if (!reference) return WritePreviewPng(path, {&left}, estimate.width, estimate.height);
  const std::vector<unsigned char> right = TonemapPreview(*reference, exposure);
  WritePreviewPng(path, {&left, &right}, estimate.width, estimate.height);
}

}  // namespace restir
