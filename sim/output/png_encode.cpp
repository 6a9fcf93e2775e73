#include "sim/output/png_encode.h"

#include <png.h>

#include <csetjmp>
#include <cstdint>
#include <stdexcept>

namespace restir {

namespace {

void Append(png_structp png, png_bytep data, png_size_t length) {
  auto* out = static_cast<std::string*>(png_get_io_ptr(png));
  out->append(reinterpret_cast<const char*>(data), length);
}

void Warn(png_structp, png_const_charp) {}

// `palette` for kPalette only. Deflated at zlib's fastest level, libpng choosing each row's filter:
// heat maps and masks are mostly runs of equal bytes, which the fastest level already finds.
enum class Colour { kGrey, kPalette, kRgb };

std::string Encode(const std::vector<unsigned char>& pixels, int w, int h, Colour colour, const unsigned char* palette) {
  const size_t channels = colour == Colour::kRgb ? 3 : 1;
  if (w < 1 || h < 1 || pixels.size() != static_cast<size_t>(w) * h * channels)
    throw std::runtime_error("cannot encode a PNG: pixel count does not match its size");
  std::string out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, Warn);
  if (!png) throw std::runtime_error("cannot encode a PNG: libpng did not start");
  png_infop info = png_create_info_struct(png);
  // libpng reports its errors by longjmp to here (nothing below owns a destructor that this would skip).
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("cannot encode a PNG: libpng failed");
  }
  png_set_write_fn(png, &out, Append, nullptr);
  png_set_IHDR(png, info, static_cast<png_uint_32>(w), static_cast<png_uint_32>(h), 8,
               colour == Colour::kPalette ? PNG_COLOR_TYPE_PALETTE
               : colour == Colour::kRgb   ? PNG_COLOR_TYPE_RGB
                                          : PNG_COLOR_TYPE_GRAY,
               PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_color colours[256];
  if (colour == Colour::kPalette) {
    for (int i = 0; i < 256; ++i) colours[i] = {palette[3 * i], palette[3 * i + 1], palette[3 * i + 2]};
    png_set_PLTE(png, info, colours, 256);
  }
  png_set_compression_level(png, 1);
  if (colour == Colour::kRgb) {
    png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
  }
  png_write_info(png, info);
  for (int y = 0; y < h; ++y) png_write_row(png, const_cast<png_bytep>(pixels.data() + static_cast<size_t>(y) * w * channels));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

}  // namespace

std::string EncodeIndexedPng(const std::vector<unsigned char>& indices, int w, int h,
                             const std::array<unsigned char, 256 * 3>& palette) {
  return Encode(indices, w, h, Colour::kPalette, palette.data());
}

std::string EncodeRgbPng(const std::vector<unsigned char>& rgb, int w, int h) {
  return Encode(rgb, w, h, Colour::kRgb, nullptr);
}

std::string EncodeGreyPng(const std::vector<unsigned char>& grey, int w, int h) {
  return Encode(grey, w, h, Colour::kGrey, nullptr);
}

bool PngIsWhole(const std::string& bytes) {
  static const char kSignature[8] = {'\x89', 'P', 'N', 'G', '\r', '\n', '\x1a', '\n'};
  if (bytes.size() < 8 || bytes.compare(0, 8, kSignature, 8) != 0) return false;
  size_t pos = 8;
  while (bytes.size() - pos >= 12) {
    const auto byte = [&](size_t i) { return static_cast<uint32_t>(static_cast<unsigned char>(bytes[pos + i])); };
    const uint32_t length = byte(0) << 24 | byte(1) << 16 | byte(2) << 8 | byte(3);
    const bool end = bytes.compare(pos + 4, 4, "IEND") == 0;
    if (length > bytes.size() - pos - 12) return false;
    pos += 12 + size_t(length);
    if (end) return pos == bytes.size();
  }
  return false;
}

}  // namespace restir
