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

#include "sim/sequence.h"
#include "sim_binary.h"

namespace restir {
namespace {

namespace fs = std::filesystem;
using test::RunSim;
using test::ShellResult;

const std::string kModels = "/usr/share/assimp/models/";

::testing::AssertionResult HaveModel(const std::string& path) {
  if (fs::exists(path)) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << path << " is missing: the asset tests need Debian's assimp-testmodels "
         << "package (apt-get install assimp-testmodels; scripts/setup.sh installs it)";
}

std::string ReadBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

void WriteBytes(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

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
class Scratch {
 public:
  Scratch() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::path(::testing::TempDir()) / (std::string("restir_asset_bad_") + info->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~Scratch() { fs::remove_all(path_); }
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

TEST(AssetBadInput, GltfWithWrongJsonTypesIsRefused) {
  Scratch scratch;
  const std::string dir = kModels + "glTF2/wrongTypes";
  ASSERT_TRUE(HaveModel(dir));
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".gltf") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  EXPECT_GE(files.size(), 6u);
  for (const std::string& f : files) {
    const std::string m = ExpectRefused(scratch.Path(), f, Where::kInAsset);
    EXPECT_NE(m.find("was not of type"), std::string::npos) << m;
  }
}

TEST(AssetBadInput, GltfWhoseIndicesAreAllOutOfRangeIsRefused) {
  Scratch scratch;
  const std::string f = kModels + "glTF2/IndexOutOfRange/AllIndicesOutOfRange.gltf";
  ASSERT_TRUE(HaveModel(f));
  ExpectRefused(scratch.Path(), f, Where::kInAsset);
}

// IndexOutOfRange.gltf: 12 triangles, one of which uses a vertex beyond the POSITION accessor. Assimp 5.2
// drops that triangle and imports the rest, so the asset is accepted with the 11 good triangles (counted here
// from the file's index buffer) and renders.
TEST(AssetBadInput, GltfWithOneIndexOutOfRangeImportsTheGoodTrianglesAndRenders) {
  Scratch scratch;
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
  size_t good = 0;
  for (size_t t = 0; t < count / 3; ++t) {
    bool ok = true;
    for (size_t k = 0; k < 3; ++k) {
      uint16_t i = 0;
      std::memcpy(&i, bin.data() + start + 2 * (3 * t + k), 2);
      ok = ok && i < vertices;
    }
    good += ok;
  }
  EXPECT_EQ(count / 3, 12u);
  EXPECT_EQ(good, 11u);
  EXPECT_EQ(ImportedTriangles(scratch.Path(), f), good);
  ExpectRendered(scratch.Path(), f);
}

// Every file of Assimp's invalid/ folder: the ones with an extension we import are refused inside the asset,
// the others at the sequence (unsupported extension). malformed2.obj only names a material that does not
// exist (and has an empty 'f' line): Assimp gives its faces the default material, and so it is accepted and
// renders.
TEST(AssetBadInput, AssimpInvalidModelsAreRefused) {
  Scratch scratch;
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
  Scratch scratch;
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
  Scratch scratch;
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
  Scratch scratch;
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
  Scratch scratch;
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
  Scratch scratch;
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
  Scratch scratch;
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
// was ignored).
TEST(AssetBadInput, GlbFramingFaultsAreNamedOneByOne) {
  Scratch scratch;
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
    const char* said;
  };
  std::string magic = good;
  magic[0] = 'x';
  for (const Case& c : {Case{"magic", magic, "no 'glTF' magic"}, Case{"version", put(good, 4, 1), "has version 1"},
                        Case{"total", put(good, 8, size + 100), "gives its length as"},
                        Case{"type", put(good, 16, 0x4E4F5342u), "first chunk is not of type JSON"},
                        Case{"past", put(good, 12, size), "JSON chunk is"}}) {
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
  Scratch scratch;
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
