#include "sim/gltf_buffers.h"

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "sim/input_file.h"
#include "sim/sequence.h"  // InputError
#include "sim/text.h"

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

// Bytes of one component (§5.1.1 componentType) and components of one element (§5.1.2 type).
uint64_t ComponentBytes(uint64_t componentType) {
  return componentType == 5120 || componentType == 5121   ? 1
         : componentType == 5122 || componentType == 5123 ? 2
                                                          : 4;
}
uint64_t Components(const std::string& t) {
  return t == "SCALAR" ? 1
         : t == "VEC2" ? 2
         : t == "VEC3" ? 3
         : t == "VEC4" ? 4
         : t == "MAT2" ? 4
         : t == "MAT3" ? 9
         : t == "MAT4" ? 16
                       : 0;
}
bool KnownComponentType(int64_t t) {
  return t == 5120 || t == 5121 || t == 5122 || t == 5123 || t == 5125 || t == 5126;
}

int Base64Value(char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  return c == '+' ? 62 : c == '/' ? 63 : -1;
}

// The payload of a base64 data: URI (RFC 2397), or nullopt when it is not one; `mediaType` is what it
// declares.
std::optional<std::string> DecodeDataUri(const std::string& uri, std::string& mediaType) {
  const size_t comma = uri.find(',');
  if (comma == std::string::npos || comma < 12 || uri.compare(comma - 7, 7, ";base64") != 0)
    return std::nullopt;
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

// Every buffer's bytes (§3.6.1.1): a data: URI, a relative file within the size limit, or for a GLB's first
// buffer without a uri its BIN chunk; each at least byteLength long.
std::vector<std::string> ReadBuffers(const Json& doc, std::string_view glbBin, const std::string& path,
                                     size_t maxBufferBytes) {
  std::vector<std::string> buffers;
  if (!doc.contains("buffers")) return buffers;
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  // The limit holds for the asset's external buffers together, so that many files just under it cannot add
  // up.
  size_t budget = maxBufferBytes;
  for (size_t i = 0; i < doc["buffers"].size(); ++i) {
    const Json& b = doc["buffers"][i];
    const std::string at = "/buffers/" + std::to_string(i);
    std::string bytes;
    if (b.contains("uri")) {
      const std::string uri = b["uri"].get<std::string>();
      const std::string shown = Printable(uri, 64);
      if (uri.rfind("data:", 0) == 0) {
        std::string mediaType;
        const std::optional<std::string> data = DecodeDataUri(uri, mediaType);
        if (!data) Fail(path, at + "/uri is a data: URI without a valid base64 payload");
        if (mediaType != "application/octet-stream" && mediaType != "application/gltf-buffer")
          Fail(path, at + "/uri is a data: URI of media type '" + Printable(mediaType) +
                         "', not application/" +
                         "octet-stream or application/gltf-buffer (glTF 2.0 §3.6.1.1)");
        bytes = *data;
      } else {
        const size_t colon = uri.find(':'), slash = uri.find('/');
        if (colon != std::string::npos && (slash == std::string::npos || colon < slash))
          Fail(path, at + "/uri (" + shown +
                         ") is not a relative path or a data: URI, the buffers the simulator reads");
        const std::string file = (dir / PercentDecoded(uri)).string();
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
    } else if (i == 0 && !glbBin.empty()) {
      bytes = std::string(glbBin);
    } else {
      Fail(path,
           at + " has no uri and is not a binary glTF's BIN chunk: its data is nowhere (glTF 2.0 §4.4.3.3)");
    }
    const uint64_t length = U64(b, "byteLength");
    if (bytes.size() < length)
      Fail(path, at + " has byteLength " + std::to_string(length) + " but its data has " +
                     std::to_string(bytes.size()) + " bytes");
    buffers.push_back(std::move(bytes));
  }
  return buffers;
}

// Where one accessor's elements lie: element k at data[begin + k * stride], `element` bytes long.
struct AccessorSpan {
  const std::string* data = nullptr;  // nullptr: the accessor has no buffer view (all zeros, or Draco's)
  uint64_t begin = 0, stride = 0, element = 0, count = 0, componentType = 0, components = 0;
  bool normalized = false;

  // Component c of element k as a double (normalized integers mapped as glTF 2.0 §3.11 says).
  double Component(uint64_t k, uint64_t c) const {
    const char* at = data->data() + begin + k * stride + c * ComponentBytes(componentType);
    switch (componentType) {
      case 5120: {
        int8_t v;
        std::memcpy(&v, at, 1);
        return normalized ? std::max(v / 127.0, -1.0) : v;
      }
      case 5121: {
        uint8_t v;
        std::memcpy(&v, at, 1);
        return normalized ? v / 255.0 : v;
      }
      case 5122: {
        int16_t v;
        std::memcpy(&v, at, 2);
        return normalized ? std::max(v / 32767.0, -1.0) : v;
      }
      case 5123: {
        uint16_t v;
        std::memcpy(&v, at, 2);
        return normalized ? v / 65535.0 : v;
      }
      case 5125: {
        uint32_t v;
        std::memcpy(&v, at, 4);
        return v;
      }
      default: {
        float v;
        std::memcpy(&v, at, 4);
        return v;
      }
    }
  }
};

// `count` elements of `element` bytes, `stride` apart, from byte `offset` of buffer view `viewIndex`: checked
// to lie within the view (computed so that huge counts cannot wrap) and the view within its buffer.
AccessorSpan Locate(const Json& doc, const std::vector<std::string>& buffers, uint64_t viewIndex,
                    uint64_t offset, uint64_t element, uint64_t stride, uint64_t count, const std::string& at,
                    const std::string& path) {
  const Json& view = doc["bufferViews"][viewIndex];
  const std::string viewAt = "/bufferViews/" + std::to_string(viewIndex);
  const uint64_t viewOffset = U64(view, "byteOffset"), viewLength = U64(view, "byteLength");
  const uint64_t bufferIndex = U64(view, "buffer");
  const uint64_t bufferLength = U64(doc["buffers"][bufferIndex], "byteLength");
  if (viewLength > bufferLength || viewOffset > bufferLength - viewLength)
    Fail(path, viewAt + " (bytes " + std::to_string(viewOffset) + " to " +
                   std::to_string(viewOffset + viewLength) +
                   ") runs past the end of its buffer (byteLength " + std::to_string(bufferLength) + ")");
  AccessorSpan span;
  span.data = &buffers[bufferIndex];
  span.begin = viewOffset + offset;
  span.element = element;
  span.stride = stride;
  span.count = count;
  const uint64_t need = offset + element;
  if (count > 0 && (need > viewLength || (count - 1) > (viewLength - need) / stride))
    Fail(path, at + " (" + std::to_string(count) + " elements of " + std::to_string(element) +
                   " bytes, stride " + std::to_string(stride) + ", from byte " + std::to_string(offset) +
                   ") runs past the end of " + viewAt + " (byteLength " + std::to_string(viewLength) + ")");
  return span;
}

class BufferCheck {
 public:
  BufferCheck(const Json& doc, std::string_view glbBin, const std::string& path, size_t maxBufferBytes)
      : doc_(doc), path_(path), buffers_(ReadBuffers(doc, glbBin, path, maxBufferBytes)) {}

  void Check() {
    if (doc_.contains("bufferViews"))
      for (uint64_t v = 0; v < doc_["bufferViews"].size(); ++v)
        Locate(doc_, buffers_, v, 0, 0, 1, 0, "", path_);  // the view within its buffer
    const size_t accessors = doc_.contains("accessors") ? doc_["accessors"].size() : 0;
    spans_.resize(accessors);
    for (uint64_t i = 0; i < accessors; ++i) spans_[i] = Accessor(i);
    if (!doc_.contains("meshes")) return;
    for (size_t m = 0; m < doc_["meshes"].size(); ++m) {
      const Json& primitives = doc_["meshes"][m]["primitives"];
      for (size_t p = 0; p < primitives.size(); ++p)
        Primitive(primitives[p], "/meshes/" + std::to_string(m) + "/primitives/" + std::to_string(p));
    }
  }

 private:
  // Accessor i located and aligned (§3.6.2.4), its sparse part checked, its floats finite.
  AccessorSpan Accessor(uint64_t i) const {
    const Json& a = doc_["accessors"][i];
    const std::string at = "/accessors/" + std::to_string(i);
    const int64_t knownType = a["componentType"].get<int64_t>();
    const uint64_t components = Components(a["type"].get<std::string>());
    AccessorSpan span;
    // An unknown format (an open enumeration, sim/gltf_schema.cpp) is not located: no mesh reads it.
    if (!KnownComponentType(knownType) || components == 0) return span;
    const uint64_t type = static_cast<uint64_t>(knownType);
    const uint64_t element = ComponentBytes(type) * components, count = U64(a, "count");
    if (a.contains("bufferView")) {
      const uint64_t viewIndex = U64(a, "bufferView");
      const Json& view = doc_["bufferViews"][viewIndex];
      const uint64_t offset = U64(a, "byteOffset"), stride = U64(view, "byteStride", element);
      if (stride < element)
        Fail(path_, at + " has elements of " + std::to_string(element) +
                        " bytes, more than its buffer view's " + "byteStride " + std::to_string(stride) +
                        " (glTF 2.0 §3.6.2.4)");
      if ((U64(view, "byteOffset") + offset) % ComponentBytes(type) != 0)
        Fail(path_, at + " begins at byte " + std::to_string(U64(view, "byteOffset") + offset) +
                        " of its buffer, " + "not a multiple of its component's " +
                        std::to_string(ComponentBytes(type)) + " bytes (glTF 2.0 §3.6.2.4)");
      span = Locate(doc_, buffers_, viewIndex, offset, element, stride, count, at, path_);
    }
    span.componentType = type;
    span.components = components;
    span.normalized = a.value("normalized", false);
    if (span.data && type == 5126) Finite(span, at, "");
    if (a.contains("sparse")) Sparse(a, at, span);
    return span;
  }

  // A sparse accessor's indices strictly increasing and below the accessor's count, its values finite
  // (§3.6.2.3).
  void Sparse(const Json& a, const std::string& at, const AccessorSpan& base) const {
    const Json& s = a["sparse"];
    const uint64_t count = U64(s, "count");
    const Json& in = s["indices"];
    const uint64_t indexType = U64(in, "componentType");
    AccessorSpan indices =
        Locate(doc_, buffers_, U64(in, "bufferView"), U64(in, "byteOffset"), ComponentBytes(indexType),
               ComponentBytes(indexType), count, at + "/sparse/indices", path_);
    indices.componentType = indexType;
    indices.components = 1;
    const Json& values = s["values"];
    AccessorSpan v = Locate(doc_, buffers_, U64(values, "bufferView"), U64(values, "byteOffset"),
                            base.element, base.element, count, at + "/sparse/values", path_);
    v.componentType = base.componentType;
    v.components = base.components;
    double previous = -1.0;
    for (uint64_t k = 0; k < count; ++k) {
      const double index = indices.Component(k, 0);
      if (index <= previous || index >= double(U64(a, "count")))
        Fail(path_,
             at + "/sparse/indices element " + std::to_string(k) + " is " + Json(index).dump() + ": sparse " +
                 "indices must increase strictly and stay below the accessor's count (glTF 2.0 §3.6.2.3)");
      previous = index;
    }
    if (v.componentType == 5126) Finite(v, at + "/sparse/values", "");
  }

  void Finite(const AccessorSpan& span, const std::string& at, const std::string& use) const {
    for (uint64_t k = 0; k < span.count; ++k)
      for (uint64_t c = 0; c < span.components; ++c)
        if (!std::isfinite(span.Component(k, c)))
          Fail(path_, at + use + " element " + std::to_string(k) + " is " +
                          (std::isnan(span.Component(k, c)) ? "NaN" : "infinite") +
                          ": glTF stores finite floats (glTF 2.0 §3.6.2.2)");
  }

  // A primitive's indices below its vertex count and not the primitive-restart value; its normals of unit
  // length.
  void Primitive(const Json& p, const std::string& at) const {
    const Json& attributes = p["attributes"];
    if (attributes.empty()) return;
    const uint64_t vertices = U64(doc_["accessors"][attributes.begin().value().get<size_t>()], "count");
    if (p.contains("indices") && !doc_["accessors"][p["indices"].get<size_t>()].contains("sparse")) {
      const uint64_t accessor = p["indices"].get<uint64_t>();
      const AccessorSpan& span = spans_[accessor];
      const uint64_t restart = span.componentType == 5121   ? 0xffu
                               : span.componentType == 5123 ? 0xffffu
                                                            : 0xffffffffu;
      for (uint64_t k = 0; span.data && k < span.count; ++k) {
        const uint64_t value = static_cast<uint64_t>(span.Component(k, 0));
        if (value >= vertices)
          Fail(path_, at + " index " + std::to_string(k) + " (accessor " + std::to_string(accessor) +
                          ") is " + std::to_string(value) + ", past its " + std::to_string(vertices) +
                          " vertices (glTF 2.0 §3.7.2.1)");
        if (value == restart)
          Fail(path_, at + " index " + std::to_string(k) + " (accessor " + std::to_string(accessor) +
                          ") is " + std::to_string(value) +
                          ", the primitive-restart value, which glTF 2.0 §3.7.2.1 forbids");
      }
    }
    if (attributes.contains("NORMAL")) {
      const uint64_t accessor = attributes["NORMAL"].get<uint64_t>();
      const AccessorSpan& n = spans_[accessor];
      for (uint64_t k = 0; n.data && k < n.count; ++k) {
        const double x = n.Component(k, 0), y = n.Component(k, 1), z = n.Component(k, 2);
        const double length = std::sqrt(x * x + y * y + z * z);
        if (std::fabs(length - 1.0) > kUnitNormalTolerance)
          Fail(path_, at + "/attributes/NORMAL element " + std::to_string(k) + " (accessor " +
                          std::to_string(accessor) + ") has length " + Json(length).dump() +
                          ", not 1 (glTF 2.0 §3.7.2.1: normals are unit vectors)");
      }
    }
  }

  const Json& doc_;
  const std::string& path_;
  const std::vector<std::string> buffers_;
  std::vector<AccessorSpan> spans_;  // per accessor
};

}  // namespace

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

void CheckGltfBuffers(const Json& doc, std::string_view glbBin, const std::string& path,
                      size_t maxBufferBytes) {
  BufferCheck(doc, glbBin, path, maxBufferBytes).Check();
}

}  // namespace restir
