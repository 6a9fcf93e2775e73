#include "sim/assets/gltf_buffers.h"

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <utility>
#include <vector>

#include "sim/util/input_file.h"
#include "sim/util/input_error.h"
#include "sim/util/text.h"

namespace restir {

namespace {

using Json = nlohmann::json;

// |1 - |n|| beyond which a NORMAL is not of unit length: the Khronos validator's tolerance
// (unitLengthThresholdVec3).
constexpr double kUnitNormalTolerance = 0.00674;

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw InputError(OneLine(path + ": error: " + what));
}

uint64_t U64(const Json& o, const char* key, uint64_t fallback = 0) {
  const auto it = o.find(key);
  return it == o.end() ? fallback : it->get<uint64_t>();
}

// Bytes of one component (§5.1.1 componentType) and components of one element (§5.1.2 type); 0 when unknown.
uint64_t ComponentBytes(int64_t componentType) {
  switch (componentType) {
    case 5120: case 5121: return 1;
    case 5122: case 5123: return 2;
    case 5125: case 5126: return 4;
    default: return 0;
  }
}
uint64_t Components(const std::string& t) {
  return t == "SCALAR" ? 1 : t == "VEC2" ? 2 : t == "VEC3" ? 3 : t == "VEC4" ? 4 : t == "MAT2" ? 4
         : t == "MAT3" ? 9 : t == "MAT4" ? 16 : 0;
}

int Base64Value(char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  return c == '+' ? 62 : c == '/' ? 63 : -1;
}

// The payload of a base64 data: URI (RFC 2397), or nullopt when it is not one; `mediaType` is what it declares.
std::optional<std::string> DecodeDataUri(const std::string& uri, std::string& mediaType) {
  const size_t comma = uri.find(',');
  if (comma == std::string::npos || comma < 12 || uri.compare(comma - 7, 7, ";base64") != 0) return std::nullopt;
  mediaType = uri.substr(5, comma - 12);
  std::string out;
  uint32_t acc = 0;
  int bits = 0;
  size_t end = uri.size();
  while (end > comma + 1 && uri[end - 1] == '=' && uri.size() - end < 2) --end;
  for (size_t i = comma + 1; i < end; ++i) {
    const int v = Base64Value(uri[i]);
    if (v < 0) return std::nullopt;
    acc = acc << 6 | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<char>(acc >> bits & 0xff));
    }
  }
  return out;
}

std::string PercentDecoded(const std::string& uri) {
  std::string out;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      out.push_back(static_cast<char>(std::stoi(uri.substr(i + 1, 2), nullptr, 16)));
      i += 2;
    } else {
      out.push_back(uri[i]);
    }
  }
  return out;
}

// Every buffer's bytes (§3.6.1.1): a data: URI, a relative file within the size limit, or for a GLB's first
// buffer without a uri its BIN chunk; each at least byteLength long.
std::vector<std::string> ReadBuffers(const Json& doc, std::optional<std::string_view> glbBin,
                                     const std::string& path, size_t maxBufferBytes) {
  std::vector<std::string> buffers;
  if (!doc.contains("buffers")) return buffers;
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  // The limit holds for the asset's external buffers together, so that many files just under it cannot add up.
  size_t budget = maxBufferBytes;
  for (size_t i = 0; i < doc["buffers"].size(); ++i) {
    const Json& b = doc["buffers"][i];
    const std::string at = "/buffers/" + std::to_string(i);
    std::string bytes;
    // Assimp 5.2 gives a GLB's BIN chunk to its first buffer whatever that buffer's uri says, so the two must not
    // both be there: what is checked would not be what is read.
    if (i == 0 && glbBin && b.contains("uri"))
      Fail(path, at + " has a uri, but the binary glTF has a BIN chunk, which is the first buffer's data (glTF "
                      "2.0 §4.4.3.3; Assimp 5.2 reads the chunk for it)");
    if (b.contains("uri")) {
      const std::string uri = b["uri"].get<std::string>();
      const std::string shown = Printable(uri, 64);
      if (uri.rfind("data:", 0) == 0) {
        std::string mediaType;
        const std::optional<std::string> data = DecodeDataUri(uri, mediaType);
        if (!data) Fail(path, at + "/uri is a data: URI without a valid base64 payload");
        if (mediaType != "application/octet-stream" && mediaType != "application/gltf-buffer")
          Fail(path, at + "/uri is a data: URI of media type '" + Printable(mediaType) +
                         "', not application/octet-stream or application/gltf-buffer (glTF 2.0 §3.6.1.1)");
        bytes = *data;
      } else {
        const size_t colon = uri.find(':'), slash = uri.find('/');
        if (colon != std::string::npos && (slash == std::string::npos || colon < slash))
          Fail(path, at + "/uri (" + shown + ") is not a relative path or a data: URI, the buffers the " +
                         "simulator reads (no file:, http: or other scheme)");
        const std::string file = ResolveGltfUriFile((dir / uri).string());
        std::string problem;
        if (!TryReadRegularFile(file, budget, bytes, problem))
          Fail(path, at + " (" + shown + "): cannot read '" + file + "' (" +
                         (problem.rfind("larger than", 0) == 0
                              ? "with the asset's other buffers, larger than the " +
                                    FormatBytes(double(maxBufferBytes)) + " an asset's files may hold"
                              : problem) +
                         ")");
        budget -= bytes.size();
      }
    } else if (i == 0 && glbBin) {
      bytes = std::string(*glbBin);
    } else {
      Fail(path, at + " has no uri and is not a binary glTF's BIN chunk: its data is nowhere (glTF 2.0 "
                      "§4.4.3.3)");
    }
    const uint64_t length = U64(b, "byteLength");
    if (bytes.size() < length)
      Fail(path, at + " has byteLength " + std::to_string(length) + " but its data has " +
                     std::to_string(bytes.size()) + " bytes");
    buffers.push_back(std::move(bytes));
  }
  return buffers;
}

// Elements in a buffer: element k's component c at data[begin + k * stride + c * component bytes].
struct Span {
  const std::string* data = nullptr;  // nullptr: no data (an accessor without a view: zeros)
  uint64_t begin = 0, stride = 0;
};

// Component c of element k of `span`, of `componentType`, as a double (normalized integers as glTF 2.0 §3.11
// maps them).
double Read(const Span& span, uint64_t k, uint64_t c, int64_t componentType, bool normalized) {
  if (!span.data) return 0.0;
  const char* at = span.data->data() + span.begin + k * span.stride + c * ComponentBytes(componentType);
  switch (componentType) {
    case 5120: { int8_t v; std::memcpy(&v, at, 1); return normalized ? std::max(v / 127.0, -1.0) : v; }
    case 5121: { uint8_t v; std::memcpy(&v, at, 1); return normalized ? v / 255.0 : v; }
    case 5122: { int16_t v; std::memcpy(&v, at, 2); return normalized ? std::max(v / 32767.0, -1.0) : v; }
    case 5123: { uint16_t v; std::memcpy(&v, at, 2); return normalized ? v / 65535.0 : v; }
    case 5125: { uint32_t v; std::memcpy(&v, at, 4); return v; }
    default: { float v; std::memcpy(&v, at, 4); return v; }
  }
}

// An accessor's elements as a reader sees them: its view's data (or zeros), with a sparse accessor's values in
// place of the elements its indices name (§3.6.2.3).
struct AccessorData {
  bool located = false;  // false: a format glTF 2.0 does not define (no mesh reads it)
  Span base, sparseIndices, sparseValues;
  uint64_t count = 0, components = 0, sparseCount = 0;
  int64_t componentType = 0, sparseIndexType = 0;
  bool normalized = false;

  // f(k, component) for every element k in order, `component(c)` reading its component c; stops at the first
  // false. Linear: the sparse indices increase (checked before any of these calls).
  template <class F>
  void Elements(F f) const {
    uint64_t j = 0;
    for (uint64_t k = 0; k < count; ++k) {
      const bool replaced = j < sparseCount && Read(sparseIndices, j, 0, sparseIndexType, false) == double(k);
      const Span& s = replaced ? sparseValues : base;
      const uint64_t e = replaced ? j++ : k;
      if (!f(k, [&](uint64_t c) { return Read(s, e, c, componentType, normalized); })) return;
    }
  }
  // Whether every element is the view's data or a sparse value (no zeros to read past).
  bool AllZeros() const { return !base.data && sparseCount == 0; }
};

// `count` elements of `element` bytes, `stride` apart, from byte `offset` of buffer view `viewIndex`: checked to
// lie within the view (computed so that huge counts cannot wrap) and the view within its buffer.
Span Locate(const Json& doc, const std::vector<std::string>& buffers, uint64_t viewIndex, uint64_t offset,
            uint64_t element, uint64_t stride, uint64_t count, const std::string& at, const std::string& path) {
  const Json& view = doc["bufferViews"][viewIndex];
  const std::string viewAt = "/bufferViews/" + std::to_string(viewIndex);
  const uint64_t viewOffset = U64(view, "byteOffset"), viewLength = U64(view, "byteLength");
  const uint64_t bufferIndex = U64(view, "buffer");
  const uint64_t bufferLength = U64(doc["buffers"][bufferIndex], "byteLength");
  if (viewLength > bufferLength || viewOffset > bufferLength - viewLength)
    Fail(path, viewAt + " (" + std::to_string(viewLength) + " bytes from byte " + std::to_string(viewOffset) +
                   ") runs past the end of its buffer (byteLength " + std::to_string(bufferLength) + ")");
  const uint64_t need = offset + element;
  if (count > 0 && (offset > viewLength || need > viewLength || (count - 1) > (viewLength - need) / stride))
    Fail(path, at + " (" + std::to_string(count) + " elements of " + std::to_string(element) +
                   " bytes, stride " + std::to_string(stride) + ", from byte " + std::to_string(offset) +
                   ") runs past the end of " + viewAt + " (byteLength " + std::to_string(viewLength) + ")");
  return Span{&buffers[bufferIndex], viewOffset + offset, stride};
}

class BufferCheck {
 public:
  BufferCheck(const Json& doc, std::optional<std::string_view> glbBin, const std::string& path,
              size_t maxBufferBytes)
      : doc_(doc),
        path_(path),
        maxBufferBytes_(maxBufferBytes),
        buffers_(ReadBuffers(doc, glbBin, path, maxBufferBytes)) {}

  void Check() {
    if (doc_.contains("bufferViews"))
      for (uint64_t v = 0; v < doc_["bufferViews"].size(); ++v)
        Locate(doc_, buffers_, v, 0, 0, 1, 0, "", path_);  // the view within its buffer
    const size_t accessors = doc_.contains("accessors") ? doc_["accessors"].size() : 0;
    for (uint64_t i = 0; i < accessors; ++i) accessors_.push_back(Accessor(i));
    if (!doc_.contains("meshes")) return;
    for (size_t m = 0; m < doc_["meshes"].size(); ++m) {
      const Json& primitives = doc_["meshes"][m]["primitives"];
      for (size_t p = 0; p < primitives.size(); ++p)
        Primitive(primitives[p], "/meshes/" + std::to_string(m) + "/primitives/" + std::to_string(p));
    }
  }

 private:
  // Accessor i located and aligned (§3.6.2.4), its sparse part checked, its floats finite.
  AccessorData Accessor(uint64_t i) const {
    const Json& a = doc_["accessors"][i];
    const std::string at = "/accessors/" + std::to_string(i);
    AccessorData d;
    d.componentType = a["componentType"].get<int64_t>();
    d.components = Components(a["type"].get<std::string>());
    d.count = U64(a, "count");
    d.normalized = a.value("normalized", false);
    // An unknown format (an open enumeration, sim/assets/gltf_schema.cpp) is not located: no mesh reads it.
    const uint64_t bytes = ComponentBytes(d.componentType);
    if (bytes == 0 || d.components == 0) return d;
    d.located = true;
    const uint64_t element = bytes * d.components;
    if (a.contains("bufferView")) {
      const uint64_t viewIndex = U64(a, "bufferView");
      const Json& view = doc_["bufferViews"][viewIndex];
      const uint64_t offset = U64(a, "byteOffset"), stride = U64(view, "byteStride", element);
      if (stride < element)
        Fail(path_, at + " has elements of " + std::to_string(element) + " bytes, more than its buffer view's " +
                        "byteStride " + std::to_string(stride) + " (glTF 2.0 §3.6.2.4)");
      if ((U64(view, "byteOffset") + offset) % bytes != 0)
        Fail(path_, at + " begins at byte " + std::to_string(U64(view, "byteOffset") + offset) +
                        " of its buffer, not a multiple of its component's " + std::to_string(bytes) +
                        " bytes (glTF 2.0 §3.6.2.4)");
      d.base = Locate(doc_, buffers_, viewIndex, offset, element, stride, d.count, at, path_);
    } else if (d.count > maxBufferBytes_ / element) {
      // Zeros, which Assimp allocates: bounded like the data a file may hold.
      Fail(path_, at + " has no bufferView: its " + std::to_string(d.count) + " elements of zeros would take " +
                      "more than the " + FormatBytes(double(maxBufferBytes_)) + " an asset's data may hold");
    }
    if (a.contains("sparse")) {
      // Assimp 5.2 resolves a sparse accessor into packed elements, then reads them with its view's stride: past
      // the end of its allocation where the view interleaves (seen with valgrind).
      const uint64_t stride = a.contains("bufferView") ? U64(doc_["bufferViews"][U64(a, "bufferView")], "byteStride",
                                                             element)
                                                       : element;
      if (stride != element)
        Fail(path_, at + " is sparse over a buffer view of byteStride " + std::to_string(stride) + " for elements " +
                        "of " + std::to_string(element) + " bytes, which Assimp 5.2 reads past its data");
      Sparse(a, at, element, d);
    }
    // Every float finite, sparse values in place (a NaN the sparse part replaces is not read).
    if (d.componentType == 5126 && !d.AllZeros())
      d.Elements([&](uint64_t k, auto component) {
        for (uint64_t c = 0; c < d.components; ++c)
          if (!std::isfinite(component(c)))
            Fail(path_, at + " element " + std::to_string(k) + " is " +
                            (std::isnan(component(c)) ? "NaN" : "infinite") +
                            ": glTF stores finite floats (glTF 2.0 §3.6.2.2)");
        return true;
      });
    return d;
  }

  // A sparse accessor's indices strictly increasing and below the accessor's count (§3.6.2.3), located with its
  // values in `d`.
  void Sparse(const Json& a, const std::string& at, uint64_t element, AccessorData& d) const {
    const Json& s = a["sparse"];
    d.sparseCount = U64(s, "count");
    const Json& in = s["indices"];
    d.sparseIndexType = in["componentType"].get<int64_t>();
    const uint64_t indexBytes = ComponentBytes(d.sparseIndexType);
    d.sparseIndices = Locate(doc_, buffers_, U64(in, "bufferView"), U64(in, "byteOffset"), indexBytes, indexBytes,
                             d.sparseCount, at + "/sparse/indices", path_);
    const Json& values = s["values"];
    for (const auto& [part, bytes] : {std::pair<const Json*, uint64_t>{&in, indexBytes},
                                      std::pair<const Json*, uint64_t>{&values, ComponentBytes(d.componentType)}}) {
      const uint64_t begin =
          U64(doc_["bufferViews"][U64(*part, "bufferView")], "byteOffset") + U64(*part, "byteOffset");
      if (begin % bytes != 0)
        Fail(path_, at + "/sparse/" + (part == &in ? "indices" : "values") + " begin at byte " +
                        std::to_string(begin) + " of their buffer, not a multiple of their component's " +
                        std::to_string(bytes) + " bytes (glTF 2.0 §3.6.2.4)");
    }
    d.sparseValues = Locate(doc_, buffers_, U64(values, "bufferView"), U64(values, "byteOffset"), element, element,
                            d.sparseCount, at + "/sparse/values", path_);
    double previous = -1.0;
    for (uint64_t j = 0; j < d.sparseCount; ++j) {
      const double index = Read(d.sparseIndices, j, 0, d.sparseIndexType, false);
      if (index <= previous || index >= double(d.count))
        Fail(path_, at + "/sparse/indices element " + std::to_string(j) + " is " + Json(index).dump() +
                        ": sparse indices must increase strictly and stay below the accessor's count (glTF 2.0 "
                        "§3.6.2.3)");
      previous = index;
    }
  }

  // A primitive's indices below its vertex count and not the primitive-restart value; its normals of unit length.
  // Each (indices, vertex count) pair and each NORMAL accessor is read once, however many primitives share it.
  void Primitive(const Json& p, const std::string& at) {
    const Json& attributes = p["attributes"];
    const uint64_t vertices = accessors_[attributes.begin().value().get<size_t>()].count;
    if (p.contains("indices") && checkedIndices_.insert({p["indices"].get<uint64_t>(), vertices}).second) {
      const uint64_t accessor = p["indices"].get<uint64_t>();
      const AccessorData& d = accessors_[accessor];
      const double restart = d.componentType == 5121 ? 0xffu : d.componentType == 5123 ? 0xffffu : 0xffffffffu;
      if (!d.AllZeros())
        d.Elements([&](uint64_t k, auto component) {
          const double value = component(0);
          if (value >= double(vertices))
            Fail(path_, at + " index " + std::to_string(k) + " (accessor " + std::to_string(accessor) + ") is " +
                            std::to_string(uint64_t(value)) + ", past its " + std::to_string(vertices) +
                            " vertices (glTF 2.0 §3.7.2.1)");
          if (value == restart)
            Fail(path_, at + " index " + std::to_string(k) + " (accessor " + std::to_string(accessor) + ") is " +
                            std::to_string(uint64_t(value)) + ", the primitive-restart value, which glTF 2.0 " +
                            "§3.7.2.1 forbids");
          return true;
        });
    }
    if (attributes.contains("NORMAL") && checkedNormals_.insert(attributes["NORMAL"].get<uint64_t>()).second) {
      const uint64_t accessor = attributes["NORMAL"].get<uint64_t>();
      const AccessorData& d = accessors_[accessor];
      // Without a view (Draco's data, which Assimp decodes) the normals are not here to check.
      if (!d.located || (!d.base.data && p.contains("extensions") && p["extensions"].contains(
                                                                          "KHR_draco_mesh_compression")))
        return;
      d.Elements([&](uint64_t k, auto component) {
        const double x = component(0), y = component(1), z = component(2);
        const double length = std::sqrt(x * x + y * y + z * z);
        if (std::fabs(length - 1.0) > kUnitNormalTolerance)
          Fail(path_, at + "/attributes/NORMAL element " + std::to_string(k) + " (accessor " +
                          std::to_string(accessor) + ") has length " + Json(length).dump() +
                          ", not 1 (glTF 2.0 §3.7.2.1: normals are unit vectors)");
        return true;
      });
    }
  }

  const Json& doc_;
  const std::string& path_;
  const size_t maxBufferBytes_;
  const std::vector<std::string> buffers_;
  std::vector<AccessorData> accessors_;
  std::set<std::pair<uint64_t, uint64_t>> checkedIndices_;  // (accessor, vertex count) read
  std::set<uint64_t> checkedNormals_;                       // NORMAL accessors read
};

}  // namespace

std::string ResolveGltfUriFile(const std::string& joined) {
  const std::string decoded = PercentDecoded(joined);
  std::error_code ignored;
  return decoded != joined && std::filesystem::exists(decoded, ignored) ? decoded : joined;
}

void CheckGltfBuffers(const Json& doc, std::optional<std::string_view> glbBin, const std::string& path,
                      size_t maxBufferBytes) {
  BufferCheck(doc, glbBin, path, maxBufferBytes).Check();
}

}  // namespace restir
