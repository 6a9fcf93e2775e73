// libFuzzer target for the asset importer (sim/assets/asset_import.h, DESIGN §10). The first input byte chooses the
// extension (byte % 4: .gltf, .glb, .obj, .ply; '0'..'3' in the seeds), the rest is written to a file with
// that extension in a directory of this process's own, and ImportAsset, the forked path the simulator takes,
// must either return an asset that passes ValidateAsset or throw InputError with a one-line message: an
// Assimp crash, hang or runaway allocation in the child must come back as InputError, which is the property
// under test. Anything else (another exception, a crash or sanitizer report in this process) is a finding.
//
// A glTF or GLB input also goes through the glTF checks (sim/assets/gltf_document.h) in this process. Every input is
// also given, whole, to DeserializeAsset (the parent's reader of the child's bytes), and what
// it accepts to DecodeAssetTextures and ValidateAsset, as the parent does: each must return or throw
// InputError. Built by the `fuzz` preset, run by scripts/fuzz.sh; seeds in tests/fuzz/asset_seeds/,
// dictionary asset.dict.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "fuzz_message.h"
#include "importer_child.h"
#include "sim/assets/asset_import.h"
#include "sim/assets/gltf_document.h"
#include "sim/scene/sequence.h"  // InputError

RESTIR_FUZZ_SANITIZER_DEFAULTS

namespace {

std::string g_dir;  // this process's scratch directory, removed at exit
const char* const kExtensions[] = {".gltf", ".glb", ".obj", ".ply"};

void RemoveScratch() {
  std::error_code ignored;
  std::filesystem::remove_all(g_dir, ignored);
}

void CheckMessage(const restir::InputError& e) {
  const std::string message = e.what();
  if (!IsOneCleanLine(message)) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  std::string pattern = (std::filesystem::temp_directory_path() / "restir-asset-fuzz-XXXXXX").string();
  if (!::mkdtemp(pattern.data())) std::abort();
  g_dir = pattern;
  std::atexit(RemoveScratch);
  restir::fuzz::InstallImporterChildHandler();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  const bool verbose = std::getenv("RESTIR_FUZZ_VERBOSE") != nullptr;  // what each stage did, for seeds

  // The child's bytes, as the parent reads them.
  try {
    restir::ImportedAsset a = restir::DeserializeAsset(bytes, "fuzz.bytes");
    restir::DecodeAssetTextures(a);
    restir::ValidateAsset(a, "fuzz.bytes", restir::AssetLimits{});
    if (verbose) fprintf(stderr, "deserialize: accepted, %zu meshes\n", a.meshes.size());
  } catch (const restir::InputError& e) {
    CheckMessage(e);
    if (verbose) fprintf(stderr, "deserialize: %s\n", e.what());
  }

  if (size == 0) return 0;
  const std::string path = g_dir + "/input" + kExtensions[data[0] % 4];
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(bytes.data() + 1, static_cast<std::streamsize>(size - 1));
    if (!f) std::abort();
  }
  // The glTF checks, in this process (in ImportAsset they run in the forked child, where a crash would come back
  // as the child's InputError and hide): each glTF input must pass them or be refused with one clean line.
  if (data[0] % 4 < 2) {
    try {
      restir::ReadGltfDocument(bytes.substr(1), path, data[0] % 4 == 1, size_t(1) << 20);
    } catch (const restir::InputError& e) {
      CheckMessage(e);
      if (std::string(e.what()).rfind(path, 0) != 0) __builtin_trap();  // the message names the asset
    }
  }
  restir::AssetLimits limits;
  // Far below libFuzzer's -timeout (10 s in scripts/fuzz.sh), so a hang of Assimp is the child's and an
  // InputError (some malformed PLY headers loop forever in Assimp 5.2); an input of at most 16 KiB imports in
  // milliseconds.
  limits.timeoutSeconds = 2.0;
  static const bool inProcess = std::getenv("RESTIR_FUZZ_IN_PROCESS") != nullptr;
  try {
    const restir::ImportedAsset a =
        inProcess ? restir::ImportAssetInProcess(path, limits) : restir::ImportAsset(path, limits);
    restir::ValidateAsset(a, path, limits);            // ImportAsset validated it; it must stay valid
    if (!a.encodedTextures.empty()) __builtin_trap();  // the parent decodes every texture
    if (verbose)
      fprintf(stderr, "import %s: accepted, %zu meshes, %zu textures\n", path.c_str(), a.meshes.size(),
              a.textures.size());
  } catch (const restir::InputError& e) {
    CheckMessage(e);
    if (std::string(e.what()).rfind(path, 0) != 0 &&
        std::string(e.what()).find(" (a texture of " + path + ")") == std::string::npos)
      __builtin_trap();  // the message names the asset
    if (verbose) fprintf(stderr, "import: %s\n", e.what());
  }
  return 0;
}
