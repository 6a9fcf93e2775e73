#include "sim/assets/gltf_document.h"

#include <cstdint>
#include <cstring>
#include <set>
#include <string_view>
#include <vector>

#include "sim/assets/gltf_buffers.h"
#include "sim/assets/gltf_schema.h"
#include "sim/util/input_error.h"
#include "sim/util/text.h"

namespace restir {

namespace {

constexpr uint32_t kChunkJson = 0x4E4F534Au;  // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942u;   // "BIN\0"
constexpr size_t kMaxJsonDepth = 256;

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw InputError(OneLine(path + ": error: " + what));
}

// The JSON and BIN chunks of a GLB file, after checking its framing as the glTF 2.0 specification defines it
// ("GLB File Format"): a 12-byte header (magic "glTF", version 2, the file's total length), then chunks of
// (length, type, data) with lengths multiples of 4, the first of type JSON and not empty, a BIN chunk only
// second, no type twice, each within the file. Each way a file can break this gets its own message, so a
// cut-short download reads as one and not as a file of another kind.
GltfDocument GlbChunks(const std::string& bytes, const std::string& path, std::string_view& json) {
  auto u32 = [&](size_t at) {
    uint32_t v = 0;
    std::memcpy(&v, bytes.data() + at, 4);
    return v;
  };
  const std::string size = std::to_string(bytes.size());
  if (bytes.size() < 4 || bytes.compare(0, 4, "glTF") != 0)
    Fail(path, "not a binary glTF file (no 'glTF' magic)");
  if (bytes.size() < 12)
    Fail(path, "the binary glTF is cut short in its 12-byte header (the file has " + size + " bytes)");
  if (u32(4) != 2)
    Fail(path, "the binary glTF has version " + std::to_string(u32(4)) + " (only glTF 2.0 is read)");
  const uint64_t total = u32(8);
  if (total != bytes.size())
    Fail(path, "the binary glTF's header gives its length as " + std::to_string(total) +
                   " bytes but the file has " + size +
                   (total > bytes.size() ? " (the file is cut short)" : ""));
  if (bytes.size() < 20)
    Fail(path, "the binary glTF has no chunk after its header (the file has " + size + " bytes)");
  GltfDocument doc;
  bool sawBin = false;
  for (uint64_t at = 12, chunk = 0; at < bytes.size(); ++chunk) {
    if (bytes.size() - at < 8)
      Fail(path, "the binary glTF is cut short in a chunk header at byte " + std::to_string(at));
    const uint64_t length = u32(static_cast<size_t>(at)), type = u32(static_cast<size_t>(at + 4));
    const std::string which = chunk == 0 ? "JSON chunk" : "chunk at byte " + std::to_string(at);
    if (chunk == 0 && type != kChunkJson) Fail(path, "the binary glTF's first chunk is not of type JSON");
    if (length > bytes.size() - at - 8)
      Fail(path, "the binary glTF's " + which + " is " + std::to_string(length) +
                     " bytes long and runs past the " + "end of the file (" +
                     std::to_string(bytes.size() - at - 8) + " bytes follow its chunk header)");
    if (length % 4 != 0)
      Fail(path, "the binary glTF's " + which + " is " + std::to_string(length) +
                     " bytes long, not a multiple of 4");
    if (chunk == 0 && length == 0) Fail(path, "the binary glTF's JSON chunk is empty");
    if (chunk > 0 && type == kChunkJson)
      Fail(path, "the binary glTF has a second JSON chunk at byte " + std::to_string(at));
    if (type == kChunkBin) {
      if (sawBin) Fail(path, "the binary glTF has a second BIN chunk at byte " + std::to_string(at));
      if (chunk != 1)
        Fail(path, "the binary glTF's BIN chunk at byte " + std::to_string(at) + " is not its second");
      sawBin = true;
      doc.bin = std::string_view(bytes).substr(static_cast<size_t>(at + 8), static_cast<size_t>(length));
    }
    if (chunk == 0) json = std::string_view(bytes).substr(20, static_cast<size_t>(length));
    at += 8 + length;  // chunks of an unknown type are skipped, as readers must
  }
  return doc;
}

// The glTF JSON (`what` names it in messages), refusing what readers would read differently: a byte-order mark
// and a NUL byte (glTF 2.0 §3.2 wants UTF-8 JSON without a BOM; a GLB pads its JSON chunk with spaces, and a NUL
// ends nlohmann's input early), a key given twice in one object (Assimp reads the first, nlohmann and the Khronos
// validator the last, so what is checked would not be what is imported), and nesting deeper than kMaxJsonDepth
// (Assimp's JSON reader recurses once a level; no glTF needs more).
nlohmann::json ParseJson(std::string_view json, const std::string& path, const std::string& what) {
  if (json.substr(0, 3) == "\xEF\xBB\xBF")
    Fail(path, what + " begins with a byte-order mark, which glTF 2.0 forbids (§3.2: JSON in UTF-8 without one)");
  if (const size_t nul = json.find('\0'); nul != std::string_view::npos)
    Fail(path, what + " holds a NUL byte at byte " + std::to_string(nul) + ", which JSON does not (a binary glTF "
                      "pads its JSON chunk with spaces)");
  // The open objects and arrays: an object's current key (its set of keys beside), "*" for an array.
  struct Frame {
    std::string name;
    bool object = false;
    std::set<std::string> keys;
  };
  std::vector<Frame> open;
  auto pointer = [&]() {  // of the innermost open object, array positions as '*'
    std::string p;
    for (size_t i = 0; i + 1 < open.size(); ++i) p += "/" + open[i].name;
    return p.empty() ? std::string("the top-level object") : p;
  };
  using Event = nlohmann::json::parse_event_t;
  auto check = [&](int, Event event, nlohmann::json& parsed) {
    if (event == Event::object_start || event == Event::array_start) {
      if (open.size() >= kMaxJsonDepth)
        Fail(path, what + " nests objects and arrays deeper than " + std::to_string(kMaxJsonDepth) + " levels, " +
                       "at " + pointer() + " (Assimp's JSON reader recurses once a level)");
      open.push_back(Frame{event == Event::array_start ? "*" : "", event == Event::object_start, {}});
    } else if (event == Event::object_end || event == Event::array_end) {
      open.pop_back();
    } else if (event == Event::key) {
      const std::string key = parsed.get<std::string>();
      if (!open.back().keys.insert(key).second)
        Fail(path, pointer() + " has the key '" + Printable(key) + "' twice (readers disagree on which one " +
                       "counts: Assimp 5.2 reads the first, the Khronos validator the last)");
      open.back().name = key;
    }
    return true;
  };
  try {
    return nlohmann::json::parse(json.begin(), json.end(), check);
  } catch (const nlohmann::json::exception& e) {  // a parse error, or a number past a double's range (406)
    std::string message = e.what();
    const size_t bracket = message.find("] ");
    if (bracket != std::string::npos) message = message.substr(bracket + 2);
    Fail(path, what + " is not JSON: " + Printable(message, 200));
  }
}

}  // namespace

GltfDocument ReadGltfDocument(const std::string& bytes, const std::string& path, bool binary,
                              size_t maxBufferBytes) {
  std::string_view json = bytes;
  GltfDocument doc = binary ? GlbChunks(bytes, path, json) : GltfDocument{};
  doc.json = ParseJson(json, path, binary ? "the binary glTF's JSON chunk" : "the file");
  CheckGltfSchema(doc.json, path);
  CheckGltfBuffers(doc.json, doc.bin, path, maxBufferBytes);
  return doc;
}

}  // namespace restir
