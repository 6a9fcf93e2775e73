#include "sim/reference/reference_cache.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string_view>

#include "sim/util/hash.h"
#include "sim/util/text.h"

namespace restir {

namespace {

constexpr char kMagic[8] = {'R', 'S', 'R', 'E', 'F', '0', '0', '4'};

template <typename T>
void Put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

// A cursor over untrusted bytes: every read is bounds-checked.
class Cursor {
 public:
  explicit Cursor(const std::string& bytes) : bytes_(bytes) {}
  template <typename T>
  bool Get(T& v) {
    if (bytes_.size() - pos_ < sizeof(T)) return false;
    std::memcpy(&v, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return true;
  }
  bool Bytes(size_t n, const char*& at) {
    if (bytes_.size() - pos_ < n) return false;
    at = bytes_.data() + pos_;
    pos_ += n;
    return true;
  }
  size_t Position() const { return pos_; }

 private:
  const std::string& bytes_;
  size_t pos_ = 0;
};

size_t PayloadSize(int width, int height) {
  return static_cast<size_t>(width) * static_cast<size_t>(height) * (2 * sizeof(Vec3) + sizeof(float));
}

}  // namespace

size_t ReferenceCacheEntrySize(const std::string& key, int width, int height) {
  return sizeof(kMagic) + sizeof(uint32_t) + key.size() + 2 * sizeof(int32_t) + 2 * sizeof(double) + sizeof(uint64_t) +
         PayloadSize(width, height) + sizeof(uint64_t);
}

std::string EncodeReferenceCacheEntry(const std::string& key, const ImageRgb& mean, const ImageRgb& standardError,
                                      const std::vector<float>& lumaStandardError,
                                      const ReferenceAllocation& allocation) {
  std::string out;
  out.reserve(ReferenceCacheEntrySize(key, mean.width, mean.height));
  out.append(kMagic, sizeof(kMagic));
  Put(out, static_cast<uint32_t>(key.size()));
  out.append(key);
  Put(out, static_cast<int32_t>(mean.width));
  Put(out, static_cast<int32_t>(mean.height));
  Put(out, allocation.meanSamplesPerPixel);
  Put(out, allocation.scale);
  Put(out, static_cast<uint64_t>(PayloadSize(mean.width, mean.height)));
  out.append(reinterpret_cast<const char*>(mean.pixels.data()), mean.pixels.size() * sizeof(Vec3));
  out.append(reinterpret_cast<const char*>(standardError.pixels.data()), standardError.pixels.size() * sizeof(Vec3));
  out.append(reinterpret_cast<const char*>(lumaStandardError.data()), lumaStandardError.size() * sizeof(float));
  Put(out, Fnv1a(out.data(), out.size()));
  return out;
}

bool DecodeReferenceCacheEntry(const std::string& bytes, const std::string& key, int width, int height,
                               ImageRgb& mean, ImageRgb& standardError, std::vector<float>& lumaStandardError,
                               std::string& problem, ReferenceAllocation* allocation) {
  Cursor c(bytes);
  const char* magic = nullptr;
  if (!c.Bytes(sizeof(kMagic), magic) || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0) {
    problem = "not a reference cache entry of this version";
    return false;
  }
  // The checksum first: it covers the header too, so every later mismatch is a real one, not a flipped bit.
  uint64_t stored = 0;
  if (bytes.size() < sizeof(kMagic) + sizeof(stored)) {
    problem = "truncated";
    return false;
  }
  std::memcpy(&stored, bytes.data() + bytes.size() - sizeof(stored), sizeof(stored));
  if (Fnv1a(bytes.data(), bytes.size() - sizeof(stored)) != stored) {
    problem = "checksum mismatch: damaged or truncated";
    return false;
  }
  uint32_t keyLength = 0;
  const char* keyBytes = nullptr;
  if (!c.Get(keyLength) || !c.Bytes(keyLength, keyBytes)) {
    problem = "truncated";
    return false;
  }
  if (std::string(keyBytes, keyLength) != key) {
    problem = "written for another frame or configuration (key " + Printable(std::string_view(keyBytes, keyLength)) +
              ")";
    return false;
  }
  int32_t w = 0, h = 0;
  ReferenceAllocation spent;
  uint64_t payload = 0;
  if (!c.Get(w) || !c.Get(h) || !c.Get(spent.meanSamplesPerPixel) || !c.Get(spent.scale) || !c.Get(payload)) {
    problem = "truncated";
    return false;
  }
  if (w != width || h != height) {
    problem = "written at " + std::to_string(w) + "x" + std::to_string(h) + ", not " + std::to_string(width) + "x" +
              std::to_string(height);
    return false;
  }
  if (!(std::isfinite(spent.meanSamplesPerPixel) && spent.meanSamplesPerPixel >= 0.0 && spent.scale > 0.0 &&
        spent.scale <= 1.0)) {
    problem = "an allocation out of range";
    return false;
  }
  if (allocation) *allocation = spent;
  const char* data = nullptr;
  if (payload != PayloadSize(width, height) || !c.Bytes(payload, data) ||
      c.Position() + sizeof(stored) != bytes.size()) {
    problem = "wrong size";
    return false;
  }
  const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height);
  mean = ImageRgb(width, height);
  standardError = ImageRgb(width, height);
  std::memcpy(mean.pixels.data(), data, n * sizeof(Vec3));
  std::memcpy(standardError.pixels.data(), data + n * sizeof(Vec3), n * sizeof(Vec3));
  lumaStandardError.resize(n);
  std::memcpy(lumaStandardError.data(), data + 2 * n * sizeof(Vec3), n * sizeof(float));
  // The mean may be below 0 (the difference estimator's, sim/reference/reference_learning.h: a heavy draw of a
  // shadow can outweigh its exact part, a few pixels a frame of window_bars_pan), a standard error may not.
  auto finite = [](float v) { return std::isfinite(v); };
  auto spread = [](float v) { return std::isfinite(v) && v >= 0.0f; };
  bool ok = true;
  for (const Vec3& p : mean.pixels) ok = ok && finite(p.x) && finite(p.y) && finite(p.z);
  for (const Vec3& p : standardError.pixels) ok = ok && spread(p.x) && spread(p.y) && spread(p.z);
  for (float v : lumaStandardError) ok = ok && spread(v);
  if (!ok) problem = "a non-finite value or a negative standard error";
  return ok;
}

}  // namespace restir
