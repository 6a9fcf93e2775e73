// An imported asset (sim/assets/asset_import.h) as part of a sequence: its meshes become objects placed by the sequence
// object's keyframes, its materials and base-colour textures become the sequence's, and its emissive triangles
// become lights (docs/sequence-format.md "Assets").
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "sim/assets/asset_import.h"
#include "sim/scene/sequence.h"

namespace restir {

// How the sequence places an asset.
struct AssetPlacement {
  std::string name;                 // the sequence object's name; objects are "<name>/<mesh index>:<mesh name>"
  std::vector<TransformKey> keys;   // the sequence object's keyframes, shared by every mesh
  bool animated = false;            // the keys differ
  float emissionScale = 1.0f;       // multiplies every emission (0: the asset emits nothing)
  int32_t material = -1;            // a sequence material replacing the asset's on every mesh; -1: the asset's
};

// Bounds the expansion keeps (the reader's scene limits, so an asset cannot exceed what a sequence may hold).
struct AssetBudget {
  size_t maxSceneTriangles = 0;   // objects' triangles over the whole sequence
  size_t maxEmitterTriangles = 0; // emissive triangles over the whole sequence
  double maxWorldExtent = 0;      // every world-space point, from the origin
  double maxRadiance = 0;         // every emitter's radiance
};

// Appends the asset's objects, materials, textures and lights to `sequence`. Calls `fail` (which must throw)
// with a message on anything the sequence cannot hold: an emitter on an animated placement, a name collision,
// a budget exceeded. Zero-area and black emitters are skipped and counted in the sequence.
void AddAsset(ImportedAsset asset, const AssetPlacement& placement, const AssetBudget& budget, Sequence& sequence,
              const std::function<void(const std::string&)>& fail);

// Every triangle of the asset in one mesh (its root space), for the "mesh" shape, which takes its material from
// the sequence and ignores the asset's materials and emission.
Mesh MergeAssetMeshes(const ImportedAsset& asset);

}  // namespace restir
