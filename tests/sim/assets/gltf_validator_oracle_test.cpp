// The Khronos glTF validator as the importer's oracle (issue 37). Over every glTF and GLB of Debian's
// assimp-testmodels, the project's own assets and a grid of hand-broken (and hand-made valid) variants of
// Khronos' textured box, the importer (sim/assets/gltf_document.h, then Assimp) must refuse an asset the validator
// reports an error for and import one it passes, but for the documented differences, each printed:
//   - kTolerated: validator errors in what the simulator never reads (bounds, tangents, animations, skins, morph
//     targets, vertex colours, GPU layout rules, images no material it reads uses), which it imports;
//   - kOurRefusals: assets the validator passes that the simulator refuses for a reason the validator does not
//     judge (no triangle to place, a required extension it does not read, a minVersion above 2.0).
// docs/sequence-format.md lists both. Each variant also states whether it is meant to be valid, and the
// validator must agree, so the grid cannot drift into testing nothing. The validator is npm's gltf-validator
// at the version tests/tools/gltf_validator/package-lock.json pins (scripts/setup.sh --with-gltf-validator);
// without it the test is skipped, unless RESTIR_REQUIRE_GLTF_VALIDATOR=1 (CI), when that is a failure.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "sim/assets/asset_import.h"
#include "sim/scene/sequence.h"
#include "tests/sim/asset_fixtures.h"
#include "tests/sim/sim_binary.h"

namespace restir {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

using test::kModels;
using test::ReadBytes;
using test::WriteBytes;
const std::string kValidatorDir = "tests/tools/gltf_validator";

// Validator error codes the importer tolerates, with the reason (docs/sequence-format.md, "Assets").
const std::map<std::string, std::string> kTolerated = {
    {"ACCESSOR_MIN_MISMATCH", "accessor bounds: not read (a mesh is bounded by its vertices)"},
    {"ACCESSOR_MAX_MISMATCH", "accessor bounds: not read"},
    {"ACCESSOR_ELEMENT_OUT_OF_MIN_BOUND", "accessor bounds: not read"},
    {"ACCESSOR_ELEMENT_OUT_OF_MAX_BOUND", "accessor bounds: not read"},
    {"MESH_PRIMITIVE_POSITION_ACCESSOR_WITHOUT_BOUNDS", "accessor bounds: not read"},
    {"MESH_PRIMITIVE_NO_TANGENT_SPACE", "tangents and normal maps: not read"},
    {"ACCESSOR_INVALID_SIGN", "tangents: not read"},
    {"ACCESSOR_NON_CLAMPED", "vertex colours and skin weights: not read"},
    {"ACCESSOR_ANIMATION_INPUT_NEGATIVE", "animations: not read (the sequence's keyframes move objects)"},
    {"ACCESSOR_ANIMATION_INPUT_NON_INCREASING", "animations: not read"},
    {"ACCESSOR_ANIMATION_SAMPLER_OUTPUT_NON_NORMALIZED_QUATERNION", "animations: not read"},
    {"ANIMATION_CHANNEL_TARGET_NODE_MATRIX", "animations: not read"},
    {"ANIMATION_CHANNEL_TARGET_NODE_WEIGHTS_NO_MORPHS", "animations: not read"},
    {"ANIMATION_DUPLICATE_TARGETS", "animations: not read"},
    {"ANIMATION_SAMPLER_INPUT_ACCESSOR_INVALID_FORMAT", "animations: not read"},
    {"ANIMATION_SAMPLER_INPUT_ACCESSOR_TOO_FEW_ELEMENTS", "animations: not read"},
    {"ANIMATION_SAMPLER_INPUT_ACCESSOR_WITHOUT_BOUNDS", "animations: not read"},
    {"ANIMATION_SAMPLER_OUTPUT_ACCESSOR_INVALID_COUNT", "animations: not read"},
    {"ANIMATION_SAMPLER_OUTPUT_ACCESSOR_INVALID_FORMAT", "animations: not read"},
    {"ANIMATION_SAMPLER_ACCESSOR_WITH_BYTESTRIDE", "animations: not read"},
    {"SKIN_NO_COMMON_ROOT", "skins: not read (the bind pose is imported)"},
    {"SKIN_SKELETON_INVALID", "skins: not read"},
    {"SKIN_IBM_INVALID_FORMAT", "skins: not read"},
    {"SKIN_IBM_ACCESSOR_WITH_BYTESTRIDE", "skins: not read"},
    {"INVALID_IBM_ACCESSOR_COUNT", "skins: not read"},
    {"ACCESSOR_INVALID_IBM", "skins: not read"},
    {"ACCESSOR_JOINTS_INDEX_OOB", "skins: not read"},
    {"ACCESSOR_JOINTS_INDEX_DUPLICATE", "skins: not read"},
    {"ACCESSOR_WEIGHTS_NEGATIVE", "skins: not read"},
    {"ACCESSOR_WEIGHTS_NON_NORMALIZED", "skins: not read"},
    {"NODE_SKIN_WITH_NON_SKINNED_MESH", "skins: not read"},
    {"NODE_SKIN_NO_SCENE", "skins: not read"},
    {"MESH_PRIMITIVE_MORPH_TARGET_INVALID_ATTRIBUTE_COUNT",
     "morph targets: not read (the base mesh is imported)"},
    {"MESH_PRIMITIVE_MORPH_TARGET_NO_BASE_ACCESSOR", "morph targets: not read"},
    {"MESH_PRIMITIVES_UNEQUAL_TARGETS_COUNT", "morph targets: not read"},
    {"MESH_INVALID_WEIGHTS_COUNT", "morph targets: not read"},
    {"NODE_WEIGHTS_INVALID", "morph targets: not read"},
    {"MESH_PRIMITIVE_ACCESSOR_UNALIGNED", "a GPU's vertex-fetch layout: the data reads the same without it"},
    {"MESH_PRIMITIVE_ACCESSOR_WITHOUT_BYTESTRIDE", "a GPU's vertex-fetch layout"},
    {"ACCESSOR_MATRIX_ALIGNMENT", "a GPU's vertex-fetch layout"},
    {"BUFFER_VIEW_TARGET_OVERRIDE", "a GPU's vertex-fetch layout"},
    {"ACCESSOR_USAGE_OVERRIDE", "a GPU's vertex-fetch layout"},
    {"BUFFER_VIEW_INVALID_BYTE_STRIDE", "a GPU's vertex-fetch layout"},
    {"IMAGE_BUFFER_VIEW_WITH_BYTESTRIDE", "a GPU's vertex-fetch layout"},
    {"NODE_MATRIX_NON_TRS", "a node's matrix places its mesh as written, shear included"},
    {"IMAGE_DATA_INVALID",
     "images: those the materials' base-colour and emissive textures use are decoded (and "
     "refused when they cannot be), others are not read"},
    {"IMAGE_UNEXPECTED_EOS", "images: as IMAGE_DATA_INVALID"},
    {"IMAGE_MIME_TYPE_INVALID", "images: decoded by their content, whatever mimeType says"},
    {"IMAGE_NON_ENABLED_MIME_TYPE", "images: decoded by their content"},
    {"TEXTURE_INVALID_IMAGE_MIME_TYPE", "images: decoded by their content"},
    {"KHR_LIGHTS_PUNCTUAL_LIGHT_SPOT_ANGLES", "KHR_lights_punctual: not read"},
    {"KHR_MATERIALS_VARIANTS_NON_UNIQUE_VARIANT", "KHR_materials_variants: not read"},
};

// What the importer refuses although the validator passes it: the substring of its message for each reason.
const std::vector<std::pair<std::string, std::string>> kOurRefusals = {
    {"the asset has no triangles", "nothing to place: points and lines only"},
    {"the asset is incomplete", "nothing to place: a scene without nodes (Assimp's flag)"},
    {"an extension the simulator does not read", "a required extension it does not read (the spec: refuse)"},
    {"needs a reader of that glTF version", "minVersion above 2.0 (the spec: refuse)"},
    {"write integers without a fraction", "an integer written 36.0, which Assimp 5.2 does not read"},
    {"says extras should be an object", "extras that are not an object, which Assimp 5.2 does not read"},
    {"not one of TEXCOORD_0 to TEXCOORD_7", "a texture reading TEXCOORD_8 or later: Assimp 5.2 keeps eight sets"},
    {"twice (readers disagree on which one counts", "a key twice in one object: Assimp reads the first"},
    {"nests objects and arrays deeper than", "JSON nested past 256 levels: Assimp's reader recurses"},
    {"is not JSON: number overflow", "a number past a double's range"},
    {"but the binary glTF has a BIN chunk",
     "a GLB's first buffer with a uri beside a BIN chunk: Assimp reads the chunk"},
    {"neither a bufferView nor sparse values", "mesh data of zeros: Assimp 5.2 reads none"},
    {"elements of zeros would take more than", "zeros past the 1 GiB an asset's data may hold"},
    {"the asset holds more than", "more triangles than the asset limit (2^22)"},
    {"which Assimp 5.2 reads past its data", "a sparse accessor over an interleaved view: Assimp 5.2 misreads it"},
};

void Put16(std::string& b, size_t at, uint16_t v) {
  std::memcpy(&b[at], &v, 2);
}
void Put32(std::string& b, size_t at, uint32_t v) {
  std::memcpy(&b[at], &v, 4);
}
void PutFloat(std::string& b, size_t at, float v) {
  std::memcpy(&b[at], &v, 4);
}
uint16_t Get16(const std::string& b, size_t at) {
  uint16_t v;
  std::memcpy(&v, &b[at], 2);
  return v;
}
uint32_t Get32(const std::string& b, size_t at) {
  uint32_t v;
  std::memcpy(&v, &b[at], 4);
  return v;
}
std::string Base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
    if (i + 1 < bytes.size()) v |= uint32_t(uint8_t(bytes[i + 1])) << 8;
    if (i + 2 < bytes.size()) v |= uint32_t(uint8_t(bytes[i + 2]));
    out += k[v >> 18 & 63];
    out += k[v >> 12 & 63];
    out += i + 1 < bytes.size() ? k[v >> 6 & 63] : '=';
    out += i + 2 < bytes.size() ? k[v & 63] : '=';
  }
  return out;
}

// A variant of BoxTextured.gltf (its JSON and its .bin, edited), or of BoxTextured.glb (its bytes, edited).
struct GltfVariant {
  const char* name;
  bool meantValid;  // what the edit intends: the validator must agree
  std::function<void(Json&, std::string&)> edit;
};
struct GlbVariant {
  const char* name;
  bool meantValid;
  std::function<void(std::string&)> edit;
};

// BoxTextured.gltf's layout (asserted below): indices u16 at byte 768, normals at 0 and positions at 288
// (stride 12).
constexpr size_t kIndices = 768, kNormals = 0, kPositions = 288;

// The same indices as 32-bit integers in a view of their own appended to the buffer.
void WidenIndices(Json& d, std::string& bin) {
  const size_t at = bin.size();
  for (size_t k = 0; k < 36; ++k) {
    bin.append(4, '\0');
    Put32(bin, at + 4 * k, Get16(bin, kIndices + 2 * k));
  }
  d["buffers"][0]["byteLength"] = bin.size();
  d["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", 144}, {"target", 34963}});
  d["accessors"][0]["bufferView"] = d["bufferViews"].size() - 1;
  d["accessors"][0]["componentType"] = 5125;
}

void DeclareExtension(Json& d, const char* name) {
  d["extensionsUsed"].push_back(name);
}

const std::vector<GltfVariant>& GltfVariants() {
  static const std::vector<GltfVariant> v = {
      // Meant valid: each must import.
      {"untouched", true, [](Json&, std::string&) {}},
      {"emissive_strength", true,
       [](Json& d, std::string&) {
         DeclareExtension(d, "KHR_materials_emissive_strength");
         d["materials"][0]["emissiveFactor"] = {1.0, 0.5, 0.25};
         d["materials"][0]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] = 5;
       }},
      {"texture_transform", true,
       [](Json& d, std::string&) {
         DeclareExtension(d, "KHR_texture_transform");
         d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]["KHR_texture_transform"] = {
             {"offset", {0.5, 0}}, {"scale", {2, 2}}, {"rotation", 0.3}};
       }},
      {"extras_and_unknown_properties", true,
       [](Json& d, std::string&) {
         d["extras"] = {{"note", "anything"}};
         d["nodes"][1]["extras"] = {{"weights", {1, 2}}};
         d["materials"][0]["futureProperty"] = 7;
       }},
      {"application_attribute", true,
       [](Json& d, std::string&) { d["meshes"][0]["primitives"][0]["attributes"]["_TEMPERATURE"] = 3; }},
      {"version_2_1", true, [](Json& d, std::string&) { d["asset"]["version"] = "2.1"; }},
      {"trs_node", true,
       [](Json& d, std::string&) {
         d["nodes"][1]["translation"] = {1, 2, 3};
         d["nodes"][1]["rotation"] = {0, 0.6, 0, 0.8};
         d["nodes"][1]["scale"] = {2, 2, 0.5};
       }},
      {"indices_u32", true, WidenIndices},
      {"data_uri", true,
       [](Json& d, std::string& bin) {
         d["buffers"][0]["uri"] = "data:application/octet-stream;base64," + Base64(bin);
       }},
      {"sparse_positions", true,
       [](Json& d, std::string& bin) {
         const size_t at = bin.size();
         bin.append(16, '\0');  // a u16 index (padded to 4 bytes), then one VEC3
         Put16(bin, at, 5);
         for (int c = 0; c < 3; ++c) PutFloat(bin, at + 4 + 4 * c, 0.25f * (c + 1));
         d["buffers"][0]["byteLength"] = bin.size();
         d["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", 16}});
         const size_t view = d["bufferViews"].size() - 1;
         d["accessors"][2]["sparse"] = {{"count", 1},
                                        {"indices", {{"bufferView", view}, {"componentType", 5123}}},
                                        {"values", {{"bufferView", view}, {"byteOffset", 4}}}};
         d["accessors"][2].erase("min");
         d["accessors"][2].erase("max");
         d["accessors"][2]["min"] = {-0.5, -0.5, -0.5};
         d["accessors"][2]["max"] = {0.5, 0.5, 0.75};
       }},
      {"camera", true,
       [](Json& d, std::string&) {
         d["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.1}, {"zfar", 100}}}}};
         d["nodes"][1]["camera"] = 0;
       }},
      // glTF's enumerations are open (a later version may add values): an unknown one is the validator's warning.
      {"alpha_mode_unknown", true, [](Json& d, std::string&) { d["materials"][0]["alphaMode"] = "FOO"; }},
      {"sampler_wrap_unknown", true, [](Json& d, std::string&) { d["samplers"][0]["wrapS"] = 1234; }},
      {"unused_accessor_of_unknown_type", true,
       [](Json& d, std::string&) {
         d["accessors"].push_back({{"componentType", 5124}, {"count", 3}, {"type", "VEC5"}});
       }},
      {"second_uv_set", true,
       [](Json& d, std::string&) {
         d["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"] = 3;
         d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = 1;
       }},
      // Meant broken: the audit first (each was imported silently), then one fault per rule.
      {"index_1000", false, [](Json&, std::string& bin) { Put16(bin, kIndices + 8, 1000); }},
      {"index_ffff", false, [](Json&, std::string& bin) { Put16(bin, kIndices + 8, 0xffff); }},
      {"index_u32_ffffffff", false,
       [](Json& d, std::string& bin) {
         WidenIndices(d, bin);
         Put32(bin, bin.size() - 144 + 16, 0xffffffffu);
       }},
      {"index_u32_past_end", false,
       [](Json& d, std::string& bin) {
         WidenIndices(d, bin);
         Put32(bin, bin.size() - 144 + 16, 24);
       }},
      {"scale_nan_string", false, [](Json& d, std::string&) { d["nodes"][1]["scale"] = {"nan", 1, 1}; }},
      {"emissive_strength_string", false,
       [](Json& d, std::string&) {
         DeclareExtension(d, "KHR_materials_emissive_strength");
         d["materials"][0]["emissiveFactor"] = {1, 1, 1};
         d["materials"][0]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] = "50";
       }},
      {"emissive_strength_negative", false,
       [](Json& d, std::string&) {
         DeclareExtension(d, "KHR_materials_emissive_strength");
         d["materials"][0]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] = -1;
       }},
      {"base_color_5", false,
       [](Json& d, std::string&) { d["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {5, 1, 1, 1}; }},
      {"base_color_1e30", false,
       [](Json& d, std::string&) { d["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {1, 1e30, 1, 1}; }},
      {"metallic_negative", false,
       [](Json& d, std::string&) { d["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] = -0.5; }},
      {"emissive_factor_2", false, [](Json& d, std::string&) { d["materials"][0]["emissiveFactor"] = {2, 0, 0}; }},
      {"accessor_past_view", false, [](Json& d, std::string&) { d["accessors"][0]["count"] = 100000; }},
      {"view_past_buffer", false, [](Json& d, std::string&) { d["bufferViews"][1]["byteLength"] = 1 << 20; }},
      {"buffer_short", false, [](Json&, std::string& bin) { bin.resize(bin.size() - 8); }},
      {"byte_length_zero", false, [](Json& d, std::string&) { d["buffers"][0]["byteLength"] = 0; }},
      {"component_type_unknown", false, [](Json& d, std::string&) { d["accessors"][3]["componentType"] = 5124; }},
      {"type_unknown", false, [](Json& d, std::string&) { d["accessors"][3]["type"] = "VEC5"; }},
      {"component_type_missing", false, [](Json& d, std::string&) { d["accessors"][0].erase("componentType"); }},
      {"normalized_float", false, [](Json& d, std::string&) { d["accessors"][1]["normalized"] = true; }},
      {"indices_normalized", false,
       [](Json& d, std::string&) {
         d["accessors"][0]["normalized"] = true;
       }},
      {"offset_misaligned", false, [](Json& d, std::string&) { d["accessors"][3]["byteOffset"] = 2; }},
      {"stride_3", false, [](Json& d, std::string&) { d["bufferViews"][2]["byteStride"] = 3; }},
      {"stride_256", false, [](Json& d, std::string&) { d["bufferViews"][2]["byteStride"] = 256; }},
      {"unequal_counts", false, [](Json& d, std::string&) { d["accessors"][3]["count"] = 23; }},
      {"attribute_name_lower_case", false,
       [](Json& d, std::string&) {
         Json& a = d["meshes"][0]["primitives"][0]["attributes"];
         a["texcoord_0"] = a["TEXCOORD_0"];
         a.erase("TEXCOORD_0");
       }},
      {"uv_set_missing", false,
       [](Json& d, std::string&) { d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = 1; }},
      {"material_negative", false, [](Json& d, std::string&) { d["meshes"][0]["primitives"][0]["material"] = -1; }},
      {"indices_past_end", false, [](Json& d, std::string&) { d["meshes"][0]["primitives"][0]["indices"] = 9; }},
      {"mode_7", false, [](Json& d, std::string&) { d["meshes"][0]["primitives"][0]["mode"] = 7; }},
      {"node_loop", false, [](Json& d, std::string&) { d["nodes"][1]["children"] = {0}; }},
      {"two_parents", false,
       [](Json& d, std::string&) {
         d["nodes"].push_back({{"children", {1}}});
         d["scenes"][0]["nodes"] = {0, 2};
       }},
      {"scene_non_root", false, [](Json& d, std::string&) { d["scenes"][0]["nodes"] = {0, 1}; }},
      {"scene_node_twice", false, [](Json& d, std::string&) { d["scenes"][0]["nodes"] = {0, 0}; }},
      {"scene_past_end", false, [](Json& d, std::string&) { d["scene"] = 5; }},
      {"nodes_empty", false,
       [](Json& d, std::string&) {
         d["nodes"] = Json::array();
         d["scenes"][0].erase("nodes");
       }},
      {"rotation_not_unit", false, [](Json& d, std::string&) { d["nodes"][1]["rotation"] = {0, 0, 0.5, 0.5}; }},
      {"matrix_and_trs", false, [](Json& d, std::string&) { d["nodes"][0]["translation"] = {1, 0, 0}; }},
      {"camera_far_before_near", false,
       [](Json& d, std::string&) {
         d["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 10}, {"zfar", 1}}}}};
         d["nodes"][1]["camera"] = 0;
       }},
      {"image_without_source", false, [](Json& d, std::string&) { d["images"][0] = Json::object(); }},
      {"version_3", false, [](Json& d, std::string&) { d["asset"]["version"] = "3.0"; }},
      {"version_1", false, [](Json& d, std::string&) { d["asset"]["version"] = "1.0"; }},
      {"asset_missing", false, [](Json& d, std::string&) { d.erase("asset"); }},
      {"extension_undeclared", false,
       [](Json& d, std::string&) {
         d["materials"][0]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] = 2;
       }},
      {"extension_not_an_object", false,
       [](Json& d, std::string&) {
         DeclareExtension(d, "KHR_materials_emissive_strength");
         d["materials"][0]["extensions"]["KHR_materials_emissive_strength"] = 5;
       }},
      {"required_not_used", false, [](Json& d, std::string&) { d["extensionsRequired"] = {"KHR_texture_transform"}; }},
      {"position_nan", false, [](Json&, std::string& bin) { PutFloat(bin, kPositions, std::nanf("")); }},
      {"position_infinite", false,
       [](Json&, std::string& bin) { PutFloat(bin, kPositions + 4, std::numeric_limits<float>::infinity()); }},
      {"uv_nan", false, [](Json&, std::string& bin) { PutFloat(bin, 576 + 8, std::nanf("")); }},
      {"normal_zero", false,
       [](Json&, std::string& bin) {
         for (int c = 0; c < 3; ++c) PutFloat(bin, kNormals + 4 * c, 0.0f);
       }},
      {"normal_long", false, [](Json&, std::string& bin) { PutFloat(bin, kNormals + 12 * 3 + 4, 1.5f); }},
      {"data_uri_text_plain", false,
       [](Json& d, std::string& bin) { d["buffers"][0]["uri"] = "data:text/plain;base64," + Base64(bin); }},
      // The validator passes these; the simulator refuses them for a reason of its own (kOurRefusals).
      {"required_unknown_extension", true,
       [](Json& d, std::string&) {
         d["extensionsUsed"] = {"EXT_unknown_to_everyone"};
         d["extensionsRequired"] = {"EXT_unknown_to_everyone"};
       }},
      {"min_version_2_1", true,
       [](Json& d, std::string&) {
         d["asset"]["version"] = "2.1";
         d["asset"]["minVersion"] = "2.1";
       }},
      {"extras_not_an_object", true, [](Json& d, std::string&) { d["nodes"][1]["extras"] = Json::array({1, 2}); }},
      {"count_as_float", true, [](Json& d, std::string&) { d["accessors"][0]["count"] = 36.0; }},
      {"points_only", true, [](Json& d, std::string&) { d["meshes"][0]["primitives"][0]["mode"] = 0; }},
  };
  return v;
}

const std::vector<GlbVariant>& GlbVariants() {
  static const std::vector<GlbVariant> v = {
      {"untouched", true, [](std::string&) {}},
      {"unknown_chunk_appended", true,
       [](std::string& b) {
         b += std::string("\x08\0\0\0XTRA", 8) + std::string(8, '\0');
         Put32(b, 8, static_cast<uint32_t>(b.size()));
       }},
      {"magic", false, [](std::string& b) { b[0] = 'x'; }},
      {"version_1", false, [](std::string& b) { Put32(b, 4, 1); }},
      {"total_length_plus_100", false,
       [](std::string& b) { Put32(b, 8, static_cast<uint32_t>(b.size() + 100)); }},
      {"cut_short", false, [](std::string& b) { b.resize(b.size() - 100); }},
      {"header_only", false,
       [](std::string& b) {
         b.resize(12);
         Put32(b, 8, 12);
       }},
      {"cut_in_chunk_header", false,
       [](std::string& b) {
         b.resize(16);
         Put32(b, 8, 16);
       }},
      {"json_chunk_past_end", false, [](std::string& b) { Put32(b, 12, static_cast<uint32_t>(b.size())); }},
      {"json_chunk_cut_short", false,
       [](std::string& b) {
         const uint32_t json = Get32(b, 12);
         b.resize(20 + json / 2);
         Put32(b, 8, static_cast<uint32_t>(b.size()));
       }},
      {"json_chunk_unaligned", false, [](std::string& b) { Put32(b, 12, Get32(b, 12) - 1); }},
      {"first_chunk_bin", false, [](std::string& b) { Put32(b, 16, 0x004E4942u); }},
      {"bin_chunk_past_end", false,
       [](std::string& b) {
         const size_t bin = 20 + Get32(b, 12);
         Put32(b, bin, Get32(b, bin) + 64);
       }},
      {"bin_chunk_twice", false,
       [](std::string& b) {
         const size_t bin = 20 + Get32(b, 12);
         b += b.substr(bin);
         Put32(b, 8, static_cast<uint32_t>(b.size()));
       }},
  };
  return v;
}

struct Verdict {
  bool rejected = false;            // the validator could not read it as glTF or GLB
  std::vector<std::string> errors;  // "CODE@pointer"
};

// The validator's verdict on each file, or an empty map when it cannot be run.
std::map<std::string, Verdict> Validate(const std::vector<std::string>& files, std::string& problem) {
  std::string command = "node " + kValidatorDir + "/validate.js";
  for (const std::string& f : files) command += " '" + f + "'";
  const test::ShellResult r = test::Shell(command + " 2>&1");
  std::map<std::string, Verdict> out;
  if (!r.exited || r.status != 0) {
    problem = "the validator failed (exit " + std::to_string(r.status) + "): " + r.output.substr(0, 400);
    return {};
  }
  std::istringstream lines(r.output);
  for (std::string line; std::getline(lines, line);) {
    const Json j = Json::parse(line);
    Verdict& v = out[j.at("file").get<std::string>()];
    v.rejected = j.contains("rejected");
    if (j.contains("errors")) v.errors = j["errors"].get<std::vector<std::string>>();
  }
  if (out.size() != files.size())
    problem = "the validator answered for " + std::to_string(out.size()) + " of " +
              std::to_string(files.size()) + " files";
  return out;
}

std::string Code(const std::string& error) {
  return error.substr(0, error.find('@'));
}

class GltfValidatorOracle : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kValidatorDir + "/node_modules/gltf-validator/package.json") ||
        test::Shell("node --version >/dev/null 2>&1").status != 0) {
      const char* require = std::getenv("RESTIR_REQUIRE_GLTF_VALIDATOR");
      if (require && std::string(require) == "1")
        FAIL() << "the glTF validator is not installed (scripts/setup.sh --with-gltf-validator) and "
                  "RESTIR_REQUIRE_GLTF_VALIDATOR=1";
      GTEST_SKIP() << "the glTF validator is not installed: scripts/setup.sh --with-gltf-validator";
    }
    scratch_ = fs::path(::testing::TempDir()) / "restir_gltf_oracle";
    fs::remove_all(scratch_);
    fs::create_directories(scratch_);
  }
  // Kept after a failure (with the test's scratch directory), and copied to the directory
  // RESTIR_KEEP_GLTF_VARIANTS names, to run the validator and the importer on a variant by hand.
  void TearDown() override {
    if (scratch_.empty()) return;
    if (const char* keep = std::getenv("RESTIR_KEEP_GLTF_VARIANTS"))
      fs::copy(scratch_, keep, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
    if (!HasFailure()) fs::remove_all(scratch_);
  }

  // Every variant written into the scratch directory; returns the files with what each is meant to be.
  std::vector<std::pair<std::string, bool>> WriteVariants() {
    const std::string dir = kModels + "glTF2/BoxTextured-glTF/";
    const Json box = Json::parse(ReadBytes(dir + "BoxTextured.gltf"));
    const std::string bin = ReadBytes(dir + "BoxTextured0.bin");
    // The layout the edits assume.
    EXPECT_EQ(box["bufferViews"][0]["byteOffset"], kIndices);
    EXPECT_EQ(box["accessors"][1]["bufferView"], 1);
    EXPECT_EQ(box["accessors"][2]["byteOffset"], kPositions);
    EXPECT_EQ(box["bufferViews"][2]["byteOffset"], 576);
    fs::copy_file(dir + "CesiumLogoFlat.png", scratch_ / "CesiumLogoFlat.png");
    std::vector<std::pair<std::string, bool>> files;
    for (const GltfVariant& v : GltfVariants()) {
      Json d = box;
      std::string b = bin;
      const std::string name = std::string("box_") + v.name;
      d["buffers"][0]["uri"] = name + ".bin";
      v.edit(d, b);
      WriteBytes(scratch_ / (name + ".bin"), b);
      WriteBytes(scratch_ / (name + ".gltf"), d.dump());
      files.emplace_back((scratch_ / (name + ".gltf")).string(), v.meantValid);
    }
    const std::string glb = ReadBytes(kModels + "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb");
    for (const GlbVariant& v : GlbVariants()) {
      std::string b = glb;
      v.edit(b);
      const fs::path f = scratch_ / (std::string("glb_") + v.name + ".glb");
      WriteBytes(f, b);
      files.emplace_back(f.string(), v.meantValid);
    }
    // JSON nested 300 levels deep in extras (valid; the checks refuse it, as Assimp's reader recurses).
    Json deep = box;
    std::string nested = "0";
    for (int k = 0; k < 300; ++k) nested = "[" + nested + "]";
    deep["extras"] = {{"a", Json::parse(nested)}};
    deep["buffers"][0]["uri"] = "BoxTextured0.bin";
    fs::copy_file(dir + "BoxTextured0.bin", scratch_ / "BoxTextured0.bin");
    WriteBytes(scratch_ / "box_deep_extras.gltf", deep.dump());
    files.emplace_back((scratch_ / "box_deep_extras.gltf").string(), true);
    // 4.2 million triangles of zeros under one sparse vertex (valid; past the asset's triangle limit, refused
    // before Assimp allocates them).
    Json many = box;
    many["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", kIndices}, {"byteLength", 2}});    // index 0
    many["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", kPositions}, {"byteLength", 12}});  // a vertex
    Json lo = Json::array(), hi = Json::array();
    for (int c = 0; c < 3; ++c) {
      float x;
      std::memcpy(&x, &bin[kPositions + 4 * c], 4);
      lo.push_back(std::min(0.0f, x));
      hi.push_back(std::max(0.0f, x));
    }
    const size_t views = many["bufferViews"].size();
    many["accessors"].push_back(
        {{"componentType", 5126}, {"count", 12600000}, {"type", "VEC3"}, {"min", lo}, {"max", hi},
         {"sparse", {{"count", 1},
                     {"indices", {{"bufferView", views - 2}, {"componentType", 5123}}},
                     {"values", {{"bufferView", views - 1}}}}}});
    many["meshes"][0]["primitives"][0] = {{"attributes", {{"POSITION", many["accessors"].size() - 1}}}};
    WriteBytes(scratch_ / "box_many_triangles.gltf", many.dump());
    files.emplace_back((scratch_ / "box_many_triangles.gltf").string(), true);
    // The glTF fuzzer's seeds (their first byte chooses the form).
    for (const auto& e : fs::directory_iterator("tests/fuzz/gltf_seeds")) {
      const std::string seed = ReadBytes(e.path());
      const fs::path f = scratch_ / ("seed_" + e.path().stem().stem().string() + (seed[0] == '1' ? ".glb" : ".gltf"));
      WriteBytes(f, seed.substr(1));
      files.emplace_back(f.string(), true);
    }
    // A valid box whose buffer's file name holds a space (the URI escapes it).
    Json spaced = box;
    spaced["buffers"][0]["uri"] = "Box%20Textured0.bin";
    fs::copy_file(dir + "BoxTextured0.bin", scratch_ / "Box Textured0.bin");
    WriteBytes(scratch_ / "box_uri_with_space.gltf", spaced.dump());
    files.emplace_back((scratch_ / "box_uri_with_space.gltf").string(), true);
    return files;
  }

  fs::path scratch_;
};

TEST_F(GltfValidatorOracle, ImporterRefusesWhatTheValidatorReportsAndImportsWhatItPasses) {
  // The corpus: Debian's test models, the project's assets, the variants.
  std::vector<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(kModels)) {
    const std::string ext = e.path().extension().string();
    if (e.is_regular_file() && (ext == ".gltf" || ext == ".glb")) files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  ASSERT_GE(files.size(), 50u) << "Debian's assimp-testmodels is missing (scripts/setup.sh installs it)";
  for (const char* dir : {"data/assets", "tests/data/gltf_corpus"})
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.path().extension() == ".gltf" || e.path().extension() == ".glb") files.push_back(e.path().string());
  ASSERT_GE(files.size(), 110u) << "tests/data/gltf_corpus is missing";
  std::map<std::string, bool> meant;
  for (const auto& [file, valid] : WriteVariants()) {
    files.push_back(file);
    meant[file] = valid;
  }
  std::string problem;
  const std::map<std::string, Verdict> verdicts = Validate(files, problem);
  ASSERT_TRUE(problem.empty()) << problem;

  int agreed = 0, tolerated = 0, ours = 0;
  for (const std::string& file : files) {
    const Verdict& v = verdicts.at(file);
    std::vector<std::string> relevant, ignored;
    for (const std::string& e : v.errors) (kTolerated.count(Code(e)) ? ignored : relevant).push_back(e);
    const bool validatorRefuses = v.rejected || !relevant.empty();
    if (meant.count(file)) {
      EXPECT_EQ(meant[file], !v.rejected && v.errors.empty())
          << file << ": the variant is meant " << (meant[file] ? "valid" : "broken") << " but the validator "
          << (v.rejected || !v.errors.empty() ? "reports errors" : "passes it") << " (" << v.errors.size()
          << " errors)";
    }
    std::string message;
    try {
      ImportAsset(file);
    } catch (const InputError& e) {
      message = e.what();
    }
    const bool weRefuse = !message.empty();
    std::string why;
    if (weRefuse && !validatorRefuses)
      for (const auto& [phrase, reason] : kOurRefusals)
        if (message.find(phrase) != std::string::npos) why = reason;
    if (validatorRefuses) {
      EXPECT_TRUE(weRefuse) << file << ": the validator reports " << relevant.size() << " errors (first "
                            << (v.rejected ? std::string("it cannot read the file") : relevant[0])
                            << ") and the importer imports it";
      // Refused by the checks, which name what is wrong, not by Assimp's message or a crash in its child.
      EXPECT_TRUE(message.empty() || (message.find("Assimp:") == std::string::npos &&
                                      message.find("the importer ") == std::string::npos))
          << file << ": refused by Assimp rather than the checks: " << message;
      ++agreed;
    } else if (weRefuse) {
      EXPECT_FALSE(why.empty()) << file << ": the validator passes it"
                                << (ignored.empty() ? "" : " (but for tolerated " + ignored[0] + ")")
                                << " and the importer refuses it for no documented reason: " << message;
      std::cout << "[ ours     ] " << fs::path(file).filename().string() << ": refused (" << why << ")\n";
      ++ours;
    } else {
      if (!ignored.empty()) {
        std::cout << "[ tolerated] " << fs::path(file).filename().string() << ": imported despite "
                  << ignored[0] << " (" << kTolerated.at(Code(ignored[0])) << ")\n";
        ++tolerated;
      } else {
        ++agreed;
      }
    }
  }
  std::cout << "[ oracle   ] " << files.size() << " assets: " << agreed << " verdicts agree, " << tolerated
            << " imported despite tolerated errors, " << ours << " refused for the simulator's own reasons\n";
}

}  // namespace
}  // namespace restir
