// Binary serialisation for per-frame checkpoints (`restir-sim run --resume`): plain little-endian bytes of
// trivially copyable values and of vectors of them. A checkpoint is only read back by the same binary, so no
// versioning beyond a magic number and the run's configuration hash is needed. Writer and reader share their
// method names (Pod, Vector, String, Count), so one template lists a checkpoint's fields for both directions.
#pragma once

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace restir {

class BinaryWriter {
 public:
  template <typename T>
  void Pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  template <typename T>
  void Vector(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    Pod(static_cast<uint64_t>(v.size()));
    bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void String(const std::string& s) {
    Pod(static_cast<uint64_t>(s.size()));
    bytes_.append(s);
  }
  // The number of elements that follow (a reader checks it against the bytes left).
  void Count(const uint64_t& n) { Pod(n); }
  // A ByteCounter's total: the writer then allocates once, not by doubling (a checkpoint holds whole G-buffers and
  // reservoir buffers, so doubling would briefly take three times their size).
  void Reserve(size_t n) { bytes_.reserve(n); }
  const std::string& Bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

// The size a BinaryWriter would write, without writing it.
class ByteCounter {
 public:
  template <typename T>
  void Pod(const T&) {
    bytes_ += sizeof(T);
  }
  template <typename T>
  void Vector(const std::vector<T>& v) {
    bytes_ += sizeof(uint64_t) + v.size() * sizeof(T);
  }
  void String(const std::string& s) { bytes_ += sizeof(uint64_t) + s.size(); }
  void Count(const uint64_t&) { bytes_ += sizeof(uint64_t); }
  size_t Bytes() const { return bytes_; }

 private:
  size_t bytes_ = 0;
};

class BinaryReader {
 public:
  explicit BinaryReader(const std::string& bytes) : bytes_(bytes) {}
  template <typename T>
  void Pod(T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    Need(sizeof(T));
    std::memcpy(&v, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
  }
  template <typename T>
  void Vector(std::vector<T>& v) {
    uint64_t n = 0;
    Pod(n);
    if (n > (bytes_.size() - pos_) / (sizeof(T) ? sizeof(T) : 1)) throw std::runtime_error("checkpoint truncated");
    v.resize(n);
    Need(n * sizeof(T));
    if (n) std::memcpy(v.data(), bytes_.data() + pos_, n * sizeof(T));  // an empty vector's data() may be null
    pos_ += n * sizeof(T);
  }
  void String(std::string& s) {
    uint64_t n = 0;
    Pod(n);
    Need(n);
    s.assign(bytes_.data() + pos_, n);
    pos_ += n;
  }
  // At least one byte per element must remain, so a damaged count cannot make the caller allocate wildly.
  void Count(uint64_t& n) {
    Pod(n);
    Need(n);
  }
  bool AtEnd() const { return pos_ == bytes_.size(); }

 private:
  void Need(size_t n) const {
    if (n > bytes_.size() - pos_) throw std::runtime_error("checkpoint truncated");
  }
  const std::string& bytes_;
  size_t pos_ = 0;
};

}  // namespace restir
