// libFuzzer target for the glTF checks (sim/assets/gltf_document.h: GLB framing, the JSON, the document's structure,
// its binary data), in this process and without Assimp, so that it runs thousands of inputs a second where
// asset_fuzz.cpp, which forks Assimp's child for each, runs ten. The first input byte chooses the form (even: a
// .gltf, odd: a .glb; '0' and '1' in the seeds), the rest is the file's bytes, written beside no other file (so a
// relative buffer URI names nothing, and a data: URI or the BIN chunk carries the data). ReadGltfDocument must return
// or throw InputError with one clean line that begins with the file's path; anything else (another exception, a
// crash, a sanitizer report, a timeout) is a finding. Built by the `fuzz` preset, run by scripts/fuzz.sh; seeds in
// tests/fuzz/gltf_seeds/, dictionary asset.dict.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_message.h"
#include "sim/assets/gltf_document.h"
#include "sim/scene/sequence.h"  // InputError

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const bool binary = data[0] % 2 == 1;
  // A path in a directory that does not exist: an external buffer is "no such file", never a file of this machine.
  const std::string path = std::string("/nonexistent-restir-gltf-fuzz/input") + (binary ? ".glb" : ".gltf");
  const std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    restir::ReadGltfDocument(bytes, path, binary, size_t(1) << 20);
  } catch (const restir::InputError& e) {
    const std::string message = e.what();
    if (!IsOneCleanLine(message) || message.rfind(path, 0) != 0) __builtin_trap();
  }
  return 0;
}
