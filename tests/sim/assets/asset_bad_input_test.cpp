// Malformed and hostile assets through the restir-sim binary, as a user meets them (DESIGN §10): for each,
// given as a sequence object's "asset", `validate` and `run` exit with status 2 and print exactly one line,
// which begins with the asset's path (a problem inside the file: "<asset>: error: ... (asset of
// <seq>:<line>:<col> <pointer>)") or with the sequence's position (a problem with the file as a file:
// unsupported extension, not a regular file); `run` leaves nothing in its output directory or its reference
// cache. The inputs: Assimp's own malformed test models (assimp-testmodels: glTF2/wrongTypes,
// glTF2/IndexOutOfRange, invalid/, the latter also renamed to the extensions we import so Assimp's parsers
// see them), truncated .glb files, a .gltf without its buffer or its texture or with its PNG cut short (then
// the message begins with the texture's path and names the asset), OBJ files with a NaN or a 1e30 coordinate,
// a directory, /dev/zero and an unsupported extension. Two files Assimp 5.2 reads although they are damaged
// are imported and rendered, and that is asserted too.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "sim/scene/sequence.h"
#include "tests/sim/asset_fixtures.h"
#include "tests/sim/sim_binary.h"

namespace restir {
namespace {

namespace fs = std::filesystem;
using test::RunSim;
using test::ShellResult;

using test::HaveModel;
using test::kModels;
using test::ReadBytes;
using test::WriteBytes;

// Under the sanitizers (the asan preset) an allocation Assimp cannot make in the importer's child
// (OutOfMemory.off as .gltf) is a sanitizer report on the child's stderr before the child dies, which the
// parent then reports as usual; there the message must be the last line rather than the only one.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

int CountLines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

// The output's last line (with its newline): the message.
std::string MessageLine(const std::string& output) {
  const size_t end = output.size() > 0 ? output.size() - 1 : 0;
  const size_t start = output.rfind('\n', end > 0 ? end - 1 : 0);
  return start == std::string::npos || end == 0 ? output : output.substr(start + 1);
}

// A scratch directory per test, removed afterwards.
class ScratchDir {
 public:
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::path(::testing::TempDir()) / (std::string("restir_asset_bad_") + info->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~ScratchDir() { fs::remove_all(path_); }
  const fs::path& Path() const { return path_; }

 private:
  fs::path path_;
};

// A sequence that places `asset` (an absolute path) as object "thing" beside a floor and a quad light.
struct AssetSequence {
  std::string path;      // the sequence file
  std::string position;  // "<path>:<line>:<col>" of the "file" value
};

AssetSequence WriteSequence(const fs::path& dir, const std::string& asset) {
  const std::string assetLine = "    {\"name\": \"thing\", \"asset\": {\"file\": \"" + asset + "\"}}";
  const std::string text =
      "{\n"
      "  \"name\": \"asset_probe\",\n"
      "  \"resolution\": [16, 9],\n"
      "  \"frames\": 1,\n"
      "  \"materials\": [{\"name\": \"grey\", \"type\": \"diffuse\", \"albedo\": [0.6, 0.6, 0.6]}],\n"
      "  \"objects\": [\n"
      "    {\"name\": \"floor\", \"material\": \"grey\", \"shape\": {\"type\": \"quad\", \"center\": [0, 0, "
      "0], "
      "\"u\": [0, 0, 2], \"v\": [2, 0, 0]}},\n" +
      assetLine +
      "\n"
      "  ],\n"
      "  \"lights\": [{\"name\": \"key\", \"type\": \"quad\", \"center\": [0, 3, 0], \"u\": [0.25, 0, 0], "
      "\"v\": [0, 0, 0.25], \"color\": [1, 1, 1], \"intensity\": 8}],\n"
      "  \"camera\": {\"keyframes\": [{\"frame\": 0, \"position\": [0, 1, 5], \"lookAt\": [0, 0.5, 0], "
      "\"fov\": 45}]},\n"
      "  \"render\": {\"presets\": [\"ris\"], \"referenceSpp\": 16}\n"
      "}\n";
  AssetSequence s;
  s.path = (dir / "seq.json").string();
  WriteBytes(s.path, text);
  const size_t column = assetLine.find("\"file\": \"") + std::strlen("\"file\": ") + 1;  // the value's quote
  s.position = s.path + ":8:" + std::to_string(column);
  return s;
}

enum class Where {
  kInAsset,     // "<asset>: error: ... (asset of <seq>:<line>:<col> /objects/1/asset/file)"
  kInSequence,  // "<seq>:<line>:<col>: error at /objects/1/asset/file: ..."
  kInTexture,   // "<texture>: error: ... (a texture of <asset>) (asset of <seq>:<line>:<col>
                // /objects/1/asset/file)"
};

// `validate` and `run` on the asset both refuse it with one line starting where `where` says; `run` writes
// nothing. Returns validate's message. `texture` is the file a kInTexture message begins with.
std::string ExpectRefused(const fs::path& scratch, const std::string& asset, Where where,
                          const std::string& texture = "") {
  SCOPED_TRACE("asset " + asset);
  const AssetSequence seq = WriteSequence(scratch, asset);
  const std::string prefix = where == Where::kInAsset ? asset + ": error: "
                             : where == Where::kInTexture
                                 ? texture + ": error: "
                                 : seq.position + ": error at /objects/1/asset/file: ";
  const std::string origin = (where == Where::kInTexture ? " (a texture of " + asset + ")" : std::string()) +
                             " (asset of " + seq.position + " /objects/1/asset/file)\n";

  const ShellResult v = RunSim("validate " + seq.path);
  EXPECT_TRUE(v.exited) << asset << ": validate crashed";
  EXPECT_EQ(v.status, 2) << asset << ": " << v.output;
  const std::string message = MessageLine(v.output);
  if (!kSanitized) {
    EXPECT_EQ(CountLines(v.output), 1) << asset << ": " << v.output;
  }
  EXPECT_EQ(message.rfind(prefix, 0), 0u)
      << asset << "\n  got:  " << v.output << "  want: " << prefix << "...";
  if (where != Where::kInSequence) {
    EXPECT_TRUE(message.size() >= origin.size() &&
                message.compare(message.size() - origin.size(), origin.size(), origin) == 0)
        << asset << ": the message does not say where the sequence asked for it: " << v.output;
  }

  const fs::path out = scratch / "out", cache = scratch / "cache";
  fs::remove_all(out);
  fs::remove_all(cache);
  const ShellResult r =
      RunSim("run " + seq.path + " --preset ris --frames 0:1 --reference-spp 16 --no-progress --out " +
             out.string() + " --cache-dir " + cache.string());
  EXPECT_TRUE(r.exited) << asset << ": run crashed";
  EXPECT_EQ(r.status, 2) << asset << ": " << r.output;
  if (!kSanitized) {
    EXPECT_EQ(CountLines(r.output), 1) << asset << ": " << r.output;
  }
  EXPECT_EQ(MessageLine(r.output).rfind(prefix, 0), 0u) << asset << ": " << r.output;
  EXPECT_TRUE(!fs::exists(out) || fs::is_empty(out)) << asset << ": run left output in " << out;
  EXPECT_TRUE(!fs::exists(cache) || fs::is_empty(cache)) << asset << ": run left a cache entry in " << cache;
  std::cout << "[ message  ] " << message;
  return message;
}

// `validate` accepts the asset and `run` renders one frame with it: exit 0, metrics and frames written.
void ExpectRendered(const fs::path& scratch, const std::string& asset) {
  SCOPED_TRACE("asset " + asset);
  const AssetSequence seq = WriteSequence(scratch, asset);
  const ShellResult v = RunSim("validate " + seq.path);
  EXPECT_TRUE(v.exited && v.status == 0) << asset << ": " << v.output;
  const fs::path out = scratch / "out", cache = scratch / "cache";
  const ShellResult r =
      RunSim("run " + seq.path + " --preset ris --frames 0:1 --reference-spp 16 --no-progress --out " +
             out.string() + " --cache-dir " + cache.string());
  EXPECT_TRUE(r.exited) << asset << ": run crashed";
  EXPECT_EQ(r.status, 0) << asset << ": " << r.output;
  EXPECT_TRUE(fs::is_regular_file(out / "metrics.csv")) << asset;
  EXPECT_TRUE(fs::is_directory(out / "frames") && !fs::is_empty(out / "frames")) << asset;
}

// The asset's triangles as the sequence reader gives them (objects named "thing/...").
size_t ImportedTriangles(const fs::path& scratch, const std::string& asset) {
  const Sequence seq = LoadSequence(WriteSequence(scratch, asset).path);
  size_t n = 0;
  for (const Object& o : seq.objects)
    if (o.name.rfind("thing/", 0) == 0) n += o.mesh.triangles.size();
  return n;
}

// Assimp's wrongTypes models: each refused by the schema check before Assimp reads it, naming the JSON path of the
// value of the wrong type (Assimp's own message named only the member: "Member "name" was not of type ...").
TEST(AssetBadInput, GltfWithWrongJsonTypesIsRefusedNamingTheJsonPath) {
  ScratchDir scratch;
  const std::string dir = kModels + "glTF2/wrongTypes/";
  ASSERT_TRUE(HaveModel(dir));
  const std::pair<const char*, const char*> cases[] = {
      {"badArray.gltf", "/meshes/0/primitives must be an array"},
      {"badExtension.gltf", "/materials/0/pbrMetallicRoughness/baseColorTexture/extensions/KHR_texture_transform "
                            "must be an object"},
      {"badNumber.gltf", "/materials/0/normalTexture must have 'index'"},
      {"badObject.gltf", "/materials/0/pbrMetallicRoughness must be an object"},
      {"badString.gltf", "/scenes/0/name must be a string"},
      {"badUint.gltf", "/materials/0/pbrMetallicRoughness/baseColorTexture/index is -1: an index must not be negative"}};
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.path().extension() == ".gltf";
  EXPECT_EQ(files, std::size(cases)) << "a new model in " << dir;
  for (const auto& [file, said] : cases) {
    const std::string m = ExpectRefused(scratch.Path(), dir + file, Where::kInAsset);
    EXPECT_NE(m.find(said), std::string::npos) << m;
    EXPECT_NE(m.find("(glTF 2.0 schema)"), std::string::npos) << m;
  }
}

TEST(AssetBadInput, GltfWhoseIndicesAreAllOutOfRangeIsRefused) {
  ScratchDir scratch;
  const std::string f = kModels + "glTF2/IndexOutOfRange/AllIndicesOutOfRange.gltf";
  ASSERT_TRUE(HaveModel(f));
  ExpectRefused(scratch.Path(), f, Where::kInAsset);
}

// IndexOutOfRange.gltf: 12 triangles, one of which uses a vertex beyond the POSITION accessor (counted here from
// the file's index buffer). glTF 2.0 §3.7.2.1 forbids it; Assimp 5.2 drops that triangle and imported the rest, so
// the asset rendered with a hole. Refused, naming the primitive, the index and the vertex count.
TEST(AssetBadInput, GltfWithOneIndexOutOfRangeIsRefusedNamingTheIndex) {
  ScratchDir scratch;
  const std::string f = kModels + "glTF2/IndexOutOfRange/IndexOutOfRange.gltf";
  ASSERT_TRUE(HaveModel(f));
  const nlohmann::json doc = nlohmann::json::parse(ReadBytes(f));
  const nlohmann::json& prim = doc.at("meshes").at(0).at("primitives").at(0);
  const nlohmann::json& indices = doc.at("accessors").at(prim.at("indices").get<size_t>());
  ASSERT_EQ(indices.at("componentType").get<int>(), 5123);  // unsigned short
  const size_t vertices =
      doc.at("accessors").at(prim.at("attributes").at("POSITION").get<size_t>()).at("count");
  const nlohmann::json& view = doc.at("bufferViews").at(indices.at("bufferView").get<size_t>());
  const std::string bin =
      ReadBytes(kModels + "glTF2/IndexOutOfRange/" + doc.at("buffers").at(0).at("uri").get<std::string>());
  const size_t start = view.value("byteOffset", size_t(0)) + indices.value("byteOffset", size_t(0));
  const size_t count = indices.at("count");
  ASSERT_LE(start + 2 * count, bin.size());
  size_t bad = 0, firstBad = count, firstValue = 0;
  for (size_t k = 0; k < count; ++k) {
    uint16_t i = 0;
    std::memcpy(&i, bin.data() + start + 2 * k, 2);
    if (i >= vertices) {
      if (!bad) firstBad = k, firstValue = i;
      ++bad;
    }
  }
  EXPECT_EQ(count / 3, 12u);
  ASSERT_EQ(bad, 1u);
  const std::string m = ExpectRefused(scratch.Path(), f, Where::kInAsset);
  EXPECT_NE(m.find("/meshes/0/primitives/0 index " + std::to_string(firstBad) + " "), std::string::npos) << m;
  EXPECT_NE(m.find("is " + std::to_string(firstValue) + ", past its " + std::to_string(vertices) + " vertices"),
            std::string::npos)
      << m;
}

// A GLB's indices (in its BIN chunk) past the vertex count, 1000 and 0xffffffff as an audit wrote them, an accessor
// running past its buffer view, a view past its buffer, and a buffer shorter than its byteLength are each refused
// naming the JSON path; the untouched file still renders.
TEST(AssetBadInput, GltfBinaryDataOutsideItsBoundsIsRefused) {
  ScratchDir scratch;
  const std::string dir = kModels + "glTF2/BoxTextured-glTF/";
  ASSERT_TRUE(HaveModel(dir + "BoxTextured.gltf"));
  fs::copy_file(dir + "CesiumLogoFlat.png", scratch.Path() / "CesiumLogoFlat.png");
  const nlohmann::json good = nlohmann::json::parse(ReadBytes(dir + "BoxTextured.gltf"));
  const std::string goodBin = ReadBytes(dir + "BoxTextured0.bin");
  const nlohmann::json& prim = good.at("meshes").at(0).at("primitives").at(0);
  const size_t indexAccessor = prim.at("indices");
  const nlohmann::json& acc = good.at("accessors").at(indexAccessor);
  ASSERT_EQ(acc.at("componentType").get<int>(), 5123);
  const size_t view = acc.at("bufferView");
  const size_t start = good.at("bufferViews").at(view).value("byteOffset", size_t(0)) + acc.value("byteOffset", 0);
  auto write = [&](const std::string& name, const nlohmann::json& doc, const std::string& bin) {
    nlohmann::json d = doc;
    d["buffers"][0]["uri"] = name + ".bin";
    WriteBytes(scratch.Path() / (name + ".bin"), bin);
    WriteBytes(scratch.Path() / (name + ".gltf"), d.dump());
    return (scratch.Path() / (name + ".gltf")).string();
  };
  ExpectRendered(scratch.Path(), write("good", good, goodBin));
  for (uint16_t value : {uint16_t(1000), uint16_t(0xffff)}) {
    std::string bin = goodBin;
    std::memcpy(&bin[start + 2 * 4], &value, 2);  // index 4, of the second triangle
    const std::string m = ExpectRefused(scratch.Path(), write("index" + std::to_string(value), good, bin),
                                        Where::kInAsset);
    EXPECT_NE(m.find("/meshes/0/primitives/0 index 4 (accessor " + std::to_string(indexAccessor) + ") is " +
                     std::to_string(value) + ", past its"),
              std::string::npos)
        << m;
  }
  nlohmann::json longAccessor = good;
  longAccessor["accessors"][indexAccessor]["count"] = 100000;
  std::string m = ExpectRefused(scratch.Path(), write("accessor", longAccessor, goodBin), Where::kInAsset);
  EXPECT_NE(m.find("/accessors/" + std::to_string(indexAccessor) + " (100000 elements"), std::string::npos) << m;
  nlohmann::json longView = good;
  longView["bufferViews"][view]["byteLength"] = 1 << 20;
  m = ExpectRefused(scratch.Path(), write("view", longView, goodBin), Where::kInAsset);
  EXPECT_NE(m.find("/bufferViews/" + std::to_string(view) + " (1048576 bytes from byte"), std::string::npos) << m;
  EXPECT_NE(m.find("runs past the end of its buffer"), std::string::npos) << m;
  m = ExpectRefused(scratch.Path(), write("short", good, goodBin.substr(0, goodBin.size() - 8)), Where::kInAsset);
  EXPECT_NE(m.find("/buffers/0 has byteLength"), std::string::npos) << m;
  // The asset-size limit (1 GiB) holds for the external buffers together, and is applied from their sizes before
  // they are read: one sparse file of 1.5 GiB, then the box's buffer beside one of 1 GiB less 100 bytes.
  const fs::path huge = scratch.Path() / "huge.bin";
  WriteBytes(huge, "");
  fs::resize_file(huge, uint64_t(3) << 29);
  nlohmann::json hugeBuffer = good;
  hugeBuffer["buffers"][0] = {{"uri", "huge.bin"}, {"byteLength", 840}};
  WriteBytes(scratch.Path() / "huge.gltf", hugeBuffer.dump());
  m = ExpectRefused(scratch.Path(), (scratch.Path() / "huge.gltf").string(), Where::kInAsset);
  EXPECT_NE(m.find("/buffers/0 (huge.bin): cannot read"), std::string::npos) << m;
  EXPECT_NE(m.find("larger than the 1 GiB an asset's files may hold"), std::string::npos) << m;
  fs::resize_file(huge, (uint64_t(1) << 30) - 100);
  nlohmann::json twoBuffers = good;
  twoBuffers["buffers"].push_back({{"uri", "huge.bin"}, {"byteLength", 4}});
  m = ExpectRefused(scratch.Path(), write("two", twoBuffers, goodBin), Where::kInAsset);
  EXPECT_NE(m.find("/buffers/1 (huge.bin): cannot read"), std::string::npos) << m;
  EXPECT_NE(m.find("with the asset's other buffers, larger than the 1 GiB"), std::string::npos) << m;
}

// Every file of Assimp's invalid/ folder: the ones with an extension we import are refused inside the asset,
// the others at the sequence (unsupported extension). malformed2.obj only names a material that does not
// exist (and has an empty 'f' line): Assimp gives its faces the default material, and so it is accepted and
// renders.
TEST(AssetBadInput, AssimpInvalidModelsAreRefused) {
  ScratchDir scratch;
  const std::string dir = kModels + "invalid";
  ASSERT_TRUE(HaveModel(dir));
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  EXPECT_GE(files.size(), 15u);
  for (const fs::path& f : files) {
    const std::string e = f.extension().string();
    const bool supported = e == ".obj" || e == ".ply" || e == ".gltf" || e == ".glb";
    if (f.filename() == "malformed2.obj") {
      EXPECT_EQ(ImportedTriangles(scratch.Path(), f.string()), 10u);  // its five quads
      ExpectRendered(scratch.Path(), f.string());
      continue;
    }
    const std::string m =
        ExpectRefused(scratch.Path(), f.string(), supported ? Where::kInAsset : Where::kInSequence);
    if (!supported) {
      EXPECT_NE(m.find("is not a supported asset"), std::string::npos) << m;
    }
  }
}

// The same files under the extensions we import, so Assimp's OBJ, PLY and glTF parsers (and, where they give
// up, its detection by content) see them. OutOfMemory.off declares 353535235358 faces: as .gltf Assimp's OFF
// reader takes it by content and fails its allocation (std::bad_alloc, in well under a second); as .obj and
// .ply the parsers refuse it.
void ExpectRenamedInvalidModelsRefused(const char* extension) {
  ScratchDir scratch;
  const std::string dir = kModels + "invalid";
  ASSERT_TRUE(HaveModel(dir));
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string x = e.path().extension().string();
    if (x != ".obj" && x != ".ply" && x != ".gltf" && x != ".glb") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  EXPECT_GE(files.size(), 11u);
  const fs::path copies = scratch.Path() / "renamed";
  fs::create_directories(copies);
  for (const fs::path& f : files) {
    const fs::path copy = copies / (f.stem().string() + "_" + f.extension().string().substr(1) + extension);
    fs::copy_file(f, copy);
    ExpectRefused(scratch.Path(), copy.string(), Where::kInAsset);
  }
}

TEST(AssetBadInput, AssimpInvalidModelsRenamedToObjAreRefused) {
  ExpectRenamedInvalidModelsRefused(".obj");
}
TEST(AssetBadInput, AssimpInvalidModelsRenamedToPlyAreRefused) {
  ExpectRenamedInvalidModelsRefused(".ply");
}
TEST(AssetBadInput, AssimpInvalidModelsRenamedToGltfAreRefused) {
  ExpectRenamedInvalidModelsRefused(".gltf");
}

// A .glb cut short: empty, inside the 12-byte header, inside the JSON chunk header, half-way and one byte
// short.
TEST(AssetBadInput, TruncatedGlbIsRefused) {
  ScratchDir scratch;
  for (const char* model : {"glTF2/BoxTextured-glTF-Binary/BoxTextured.glb",
                            "glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"}) {
    ASSERT_TRUE(HaveModel(kModels + model));
    const std::string bytes = ReadBytes(kModels + model);
    for (size_t cut : {size_t(0), size_t(12), size_t(20), bytes.size() / 2, bytes.size() - 1}) {
      const fs::path f =
          scratch.Path() / (fs::path(model).stem().string() + "_" + std::to_string(cut) + ".glb");
      WriteBytes(f, bytes.substr(0, cut));
      ExpectRefused(scratch.Path(), f.string(), Where::kInAsset);
    }
  }
}

TEST(AssetBadInput, GltfWithoutItsBufferOrItsTextureIsRefused) {
  ScratchDir scratch;
  const std::string src = kModels + "glTF2/BoxTextured-glTF/";
  for (const char* f : {"BoxTextured.gltf", "BoxTextured0.bin", "CesiumLogoFlat.png"})
    ASSERT_TRUE(HaveModel(src + f));
  const fs::path noBin = scratch.Path() / "no_bin", noPng = scratch.Path() / "no_png";
  fs::create_directories(noBin);
  fs::create_directories(noPng);
  for (const char* f : {"BoxTextured.gltf", "CesiumLogoFlat.png"}) fs::copy_file(src + f, noBin / f);
  for (const char* f : {"BoxTextured.gltf", "BoxTextured0.bin"}) fs::copy_file(src + f, noPng / f);
  std::string m = ExpectRefused(scratch.Path(), (noBin / "BoxTextured.gltf").string(), Where::kInAsset);
  EXPECT_NE(m.find("BoxTextured0.bin"), std::string::npos) << m;
  m = ExpectRefused(scratch.Path(), (noPng / "BoxTextured.gltf").string(), Where::kInAsset);
  EXPECT_NE(m.find("CesiumLogoFlat.png"), std::string::npos) << m;
}

// A texture that is not a whole image: the message names the texture and the asset, on one line (the image
// library's own complaints must not reach stderr).
TEST(AssetBadInput, GltfWithATruncatedTextureIsRefusedWithOneLine) {
  ScratchDir scratch;
  const std::string src = kModels + "glTF2/BoxTextured-glTF/";
  for (const char* f : {"BoxTextured.gltf", "BoxTextured0.bin", "CesiumLogoFlat.png"})
    ASSERT_TRUE(HaveModel(src + f));
  const std::string png = ReadBytes(src + "CesiumLogoFlat.png");
  // Inside the signature, inside IHDR, inside PLTE, inside IDAT.
  for (size_t cut : {size_t(0), size_t(8), size_t(33), size_t(60), png.size() / 2}) {
    const fs::path dir = scratch.Path() / ("png_" + std::to_string(cut));
    fs::create_directories(dir);
    for (const char* f : {"BoxTextured.gltf", "BoxTextured0.bin"}) fs::copy_file(src + f, dir / f);
    WriteBytes(dir / "CesiumLogoFlat.png", png.substr(0, cut));
    ExpectRefused(scratch.Path(), (dir / "BoxTextured.gltf").string(), Where::kInTexture,
                  (dir / "CesiumLogoFlat.png").string());
  }
}

TEST(AssetBadInput, ObjWithNonFiniteOrHugeVertexIsRefused) {
  ScratchDir scratch;
  const fs::path nan = scratch.Path() / "nan.obj", huge = scratch.Path() / "huge.obj";
  WriteBytes(nan, "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n");
  WriteBytes(huge, "v 0 0 0\nv 1 0 0\nv 1e30 1 0\nf 1 2 3\n");
  std::string m = ExpectRefused(scratch.Path(), nan.string(), Where::kInAsset);
  EXPECT_NE(m.find("non-finite"), std::string::npos) << m;
  m = ExpectRefused(scratch.Path(), huge.string(), Where::kInAsset);
  EXPECT_NE(m.find("beyond the limit"), std::string::npos) << m;
}

// What is wrong with the file as a file is found before any import, and located in the sequence.
TEST(AssetBadInput, DirectoryDeviceAndUnsupportedExtensionAreRefusedAtTheSequence) {
  ScratchDir scratch;
  const fs::path dir = scratch.Path() / "a_directory.obj", fbx = scratch.Path() / "model.fbx";
  fs::create_directories(dir);
  WriteBytes(fbx, "Kaydara FBX Binary  \n");
  std::string m = ExpectRefused(scratch.Path(), dir.string(), Where::kInSequence);
  EXPECT_NE(m.find("a directory"), std::string::npos) << m;
  m = ExpectRefused(scratch.Path(), "/dev/zero", Where::kInSequence);
  EXPECT_NE(m.find("not a regular file"), std::string::npos) << m;
  m = ExpectRefused(scratch.Path(), fbx.string(), Where::kInSequence);
  EXPECT_NE(m.find("is not a supported asset"), std::string::npos) << m;
}

// A GLB whose framing is wrong says which part: the magic, the version, the header's total length against the
// file, the first chunk's type, a JSON chunk running past the end (each was "the first chunk is not its JSON" or
// was ignored), a chunk length that is not a multiple of 4, an empty JSON chunk, a BIN chunk twice or not second.
TEST(AssetBadInput, GlbFramingFaultsAreNamedOneByOne) {
  ScratchDir scratch;
  const std::string model = kModels + "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb";
  ASSERT_TRUE(HaveModel(model));
  const std::string good = ReadBytes(model);
  auto put = [](std::string b, size_t at, uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + k] = static_cast<char>(v >> (8 * k) & 0xff);
    return b;
  };
  const uint32_t size = static_cast<uint32_t>(good.size());
  struct Case {
    const char* name;
    std::string bytes;
    std::string said;
  };
  std::string magic = good;
  magic[0] = 'x';
  uint32_t json = 0;
  std::memcpy(&json, good.data() + 12, 4);
  const std::string bin = good.substr(20 + json);  // the BIN chunk, header and data
  const std::string twice = put(good + bin, 8, size + static_cast<uint32_t>(bin.size()));
  const std::string xtra = std::string("\x08\0\0\0XTRA", 8) + std::string(8, '\0');  // an unknown chunk, 8 bytes
  const std::string binThird = put(good.substr(0, 20 + json) + xtra + bin, 8, size + 16);
  for (const Case& c :
       {Case{"magic", magic, "no 'glTF' magic"}, Case{"version", put(good, 4, 1), "has version 1"},
        Case{"total", put(good, 8, size + 100), "gives its length as"},
        Case{"type", put(good, 16, 0x4E4F5342u), "first chunk is not of type JSON"},
        Case{"past", put(good, 12, size), "JSON chunk is"},
        Case{"unaligned", put(good, 12, json - 1), "JSON chunk is " + std::to_string(json - 1) +
                                                       " bytes long, not a multiple of 4"},
        Case{"empty", put(put(std::string(good, 0, 20), 12, 0), 8, 20), "JSON chunk is empty"},
        Case{"twice", twice, "a second BIN chunk at byte " + std::to_string(good.size())},
        Case{"third", binThird, "BIN chunk at byte " + std::to_string(20 + json + 16) + " is not its second"}}) {
    const fs::path f = scratch.Path() / (std::string("box_") + c.name + ".glb");
    WriteBytes(f, c.bytes);
    const std::string m = ExpectRefused(scratch.Path(), f.string(), Where::kInAsset);
    EXPECT_NE(m.find(c.said), std::string::npos) << c.name << ": " << m;
  }
}

// glTF numbers are checked against the schema before Assimp reads them leniently: a string where a number
// belongs, a factor outside [0, 1], a negative emissiveStrength are refused naming the JSON path inside the asset
// (Assimp read "nan" as 0, "50" as 1, and clamped 5 to 1). A factor inside its range still renders.
TEST(AssetBadInput, GltfNumbersOutsideTheSchemaAreRefusedNamingTheirPath) {
  ScratchDir scratch;
  const std::string dir = kModels + "glTF2/BoxTextured-glTF/";
  ASSERT_TRUE(HaveModel(dir + "BoxTextured.gltf"));
  for (const char* f : {"BoxTextured0.bin", "CesiumLogoFlat.png"})
    fs::copy_file(dir + f, scratch.Path() / f, fs::copy_options::overwrite_existing);
  const nlohmann::json good = nlohmann::json::parse(ReadBytes(dir + "BoxTextured.gltf"));
  struct Case {
    const char* name;
    const char* pointer;  // JSON pointer of the value set
    nlohmann::json value;
    const char* said;  // nullptr: accepted
  };
  const nlohmann::json strength = {{"KHR_materials_emissive_strength", {{"emissiveStrength", "50"}}}};
  const nlohmann::json negative = {{"KHR_materials_emissive_strength", {{"emissiveStrength", -1}}}};
  for (const Case& c :
       {Case{"scale", "/nodes/1/scale", {"nan", 1, 1}, "/nodes/1/scale/0 must be a number"},
        Case{"factor", "/materials/0/pbrMetallicRoughness/baseColorFactor", {5, 1, 1, 1},
             "/materials/0/pbrMetallicRoughness/baseColorFactor/0 is 5, outside"},
        Case{"huge", "/materials/0/pbrMetallicRoughness/baseColorFactor", {1, 1e30, 1, 1},
             "baseColorFactor/1 is 1e+30, outside"},
        Case{"strength", "/materials/0/extensions", strength,
             "/materials/0/extensions/KHR_materials_emissive_strength/emissiveStrength must be a number"},
        Case{"negative", "/materials/0/extensions", negative, "emissiveStrength is -1, outside"},
        Case{"inside", "/materials/0/pbrMetallicRoughness/baseColorFactor", {0.5, 1, 0.25, 1}, nullptr}}) {
    nlohmann::json doc = good;
    doc[nlohmann::json::json_pointer(c.pointer)] = c.value;
    const fs::path f = scratch.Path() / (std::string("box_") + c.name + ".gltf");
    WriteBytes(f, doc.dump());
    if (!c.said) {
      ExpectRendered(scratch.Path(), f.string());
      continue;
    }
    const std::string m = ExpectRefused(scratch.Path(), f.string(), Where::kInAsset);
    EXPECT_NE(m.find(c.said), std::string::npos) << c.name << ": " << m;
  }
}

}  // namespace
}  // namespace restir
