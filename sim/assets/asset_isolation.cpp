// ImportAsset: the importer in a child process (sim/util/isolation.h). Assimp 5.2 is a large C++ parser fed third-party
// files; the child imports and serialises the result (sim/assets/asset_bytes.cpp), the parent validates what it
// gets. The textures come back as the file holds them and are decoded together in one child of their own
// (sim/assets/texture.h DecodeTextures).
#include "sim/assets/asset_import.h"
#include "sim/util/isolation.h"
#include "sim/util/input_error.h"
#include "sim/util/text.h"

namespace restir {

ImportedAsset ImportAsset(const std::string& path, const AssetLimits& limits) {
  const auto work = [&](std::string& out) {
    try {
      out = SerializeAsset(ImportAssetGeometry(path, limits));
      return true;
    } catch (const InputError& e) {
      out = e.what();  // names the file already
      return false;
    }
  };
  const IsolatedResult r = RunIsolated(work, IsolatedTool{"the importer", "Assimp 5.2"},
                                       IsolationLimits{limits.timeoutSeconds, limits.maxMemoryBytes});
  if (r.status == IsolatedResult::Status::kRefused) throw InputError(r.bytes);
  if (r.status == IsolatedResult::Status::kFailed) throw InputError(OneLine(path + ": error: " + r.bytes));
  ImportedAsset asset = DeserializeAsset(r.bytes, path);
  try {
    DecodeAssetTextures(asset);
  } catch (const InputError& e) {
    throw InputError(OneLine(std::string(e.what()) + " (a texture of " + path + ")"));
  }
  ValidateAsset(asset, path, limits);
  return asset;
}

}  // namespace restir
