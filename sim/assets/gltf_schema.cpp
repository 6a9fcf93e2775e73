#include "sim/assets/gltf_schema.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <vector>

#include "sim/util/input_error.h"
#include "sim/util/text.h"

namespace restir {

namespace {

using Json = nlohmann::json;
constexpr double kInf = std::numeric_limits<double>::infinity();
const std::string kSchema = " (glTF 2.0 schema)";

// The extensions the simulator reads, so an asset may require them: Draco meshes (Assimp decodes them),
// texture transforms and emissive strength (read from the JSON by sim/assets/asset_import.cpp). A loader that does
// not support a required extension must fail to load the asset (glTF 2.0, "Specifying Extensions").
const std::set<std::string> kReadableRequired = {"KHR_draco_mesh_compression", "KHR_texture_transform",
                                                 "KHR_materials_emissive_strength"};

// |1 - |q|| beyond which a node's rotation is not a unit quaternion: the Khronos validator's tolerance
// (unitLengthThresholdVec4), so an exporter's rounding passes and a quaternion that would scale the mesh does
// not.
constexpr double kUnitQuaternionTolerance = 0.00769;

// A JSON pointer's reference token (RFC 6901): '~' as ~0, '/' as ~1.
std::string Token(const std::string& key) {
  std::string out;
  for (char c : key) out += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
  return out;
}
std::string At(const std::string& at, const std::string& key) {
  return at + "/" + Token(key);
}
std::string At(const std::string& at, size_t i) {
  return at + "/" + std::to_string(i);
}

// A value for a message: scalars as written, arrays and objects by size (dumping them whole would quote a
// megabyte, or recurse as deep as a hostile file nests them).
std::string Shown(const Json& v) {
  if (v.is_array()) return "an array of " + std::to_string(v.size()) + " elements";
  if (v.is_object()) return "an object";
  return Printable(v.dump(), 48);
}

// Components of an accessor's element (glTF 2.0 §5.1.2 accessor.type); 0 for an unknown type.
size_t Components(const std::string& type) {
  return type == "SCALAR" ? 1
         : type == "VEC2" ? 2
         : type == "VEC3" ? 3
         : type == "VEC4" ? 4
         : type == "MAT2" ? 4
         : type == "MAT3" ? 9
         : type == "MAT4" ? 16
                          : 0;
}
bool KnownComponentType(int64_t t) {
  return t == 5120 || t == 5121 || t == 5122 || t == 5123 || t == 5125 || t == 5126;
}
size_t ComponentBytes(int64_t componentType) {
  return componentType == 5120 || componentType == 5121   ? 1
         : componentType == 5122 || componentType == 5123 ? 2
                                                          : 4;
}

class Schema {
 public:
  Schema(const Json& doc, const std::string& path) : doc_(doc), path_(path) {}

  void Check() {
    if (!doc_.is_object())
      Fail("", "the glTF document must be a JSON object" + kSchema + ", not " + Shown(doc_));
    CheckAsset();
    CheckExtensionLists();
    Common(doc_, "");
    Objects(doc_, "", "accessors", &Schema::Accessor);
    Objects(doc_, "", "animations", &Schema::Animation);
    Objects(doc_, "", "buffers", &Schema::Buffer);
    Objects(doc_, "", "bufferViews", &Schema::BufferView);
    Objects(doc_, "", "cameras", &Schema::Camera);
    Objects(doc_, "", "images", &Schema::Image);
    Objects(doc_, "", "materials", &Schema::Material);
    Objects(doc_, "", "meshes", &Schema::Mesh);
    Objects(doc_, "", "nodes", &Schema::Node);
    Objects(doc_, "", "samplers", &Schema::Sampler);
    Objects(doc_, "", "scenes", &Schema::Scene);
    Objects(doc_, "", "skins", &Schema::Skin);
    Objects(doc_, "", "textures", &Schema::Texture);
    Index(doc_, "", "scene", "scenes");
    // Every object is well-typed from here on: the rules across objects.
    CheckPrimitives();
    CheckHierarchy();
    CheckExtensionsUsed();
  }

 private:
  [[noreturn]] void Fail(const std::string& at, const std::string& what) const {
    throw InputError(OneLine(path_ + ": error: " + (at.empty() ? "" : at + " ") + what));
  }

  // ---- members of one object, each with its JSON pointer: absent is fine unless required ----

  const Json* Member(const Json& o, const std::string& at, const char* key, bool required) const {
    const auto it = o.find(key);
    if (it != o.end()) return &*it;
    if (required) Fail(at.empty() ? "the document" : at, std::string("must have '") + key + "'" + kSchema);
    return nullptr;
  }
  void Expect(bool ok, const std::string& at, const char* type, const Json& v) const {
    if (!ok) Fail(at, std::string("must be ") + type + kSchema + ", not " + Shown(v));
  }
  const Json* Object(const Json& o, const std::string& at, const char* key, bool required = false) const {
    const Json* v = Member(o, at, key, required);
    if (v) Expect(v->is_object(), At(at, key), "an object", *v);
    return v;
  }
  const Json* String(const Json& o, const std::string& at, const char* key, bool required = false) const {
    const Json* v = Member(o, at, key, required);
    if (v) Expect(v->is_string(), At(at, key), "a string", *v);
    return v;
  }
  void Bool(const Json& o, const std::string& at, const char* key) const {
    if (const Json* v = Member(o, at, key, false)) Expect(v->is_boolean(), At(at, key), "true or false", *v);
  }
  void InRange(const Json& v, const std::string& at, double lo, double hi, bool aboveLo) const {
    const double x = v.get<double>();
    if (!(aboveLo ? x > lo : x >= lo) || !(x <= hi))
      Fail(at, "is " + v.dump() + ", outside the glTF 2.0 schema's range " + (aboveLo ? "(" : "[") +
                   Json(lo).dump() + ", " + (hi == kInf ? std::string("inf)") : Json(hi).dump() + "]"));
  }
  // A number in [lo, hi] ((lo, hi] when `aboveLo`).
  std::optional<double> Number(const Json& o, const std::string& at, const char* key, double lo = -kInf,
                               double hi = kInf, bool required = false, bool aboveLo = false) const {
    const Json* v = Member(o, at, key, required);
    if (!v) return std::nullopt;
    Expect(v->is_number(), At(at, key), "a number", *v);
    InRange(*v, At(at, key), lo, hi, aboveLo);
    return v->get<double>();
  }
  // A JSON integer that fits 64 bits. One written with a fraction or an exponent (36.0, 1e3), which JSON Schema
  // counts an integer, is refused as Assimp 5.2 reads no other.
  void ExpectInteger(const Json& v, const std::string& at, const char* type) const {
    if (v.is_number_float() && v.get<double>() == std::floor(v.get<double>())) {
      if (std::fabs(v.get<double>()) >= 9.2e18) Fail(at, "is " + v.dump() + ", past a 64-bit integer's range");
      Fail(at, "is written " + v.dump() + ": write integers without a fraction (Assimp 5.2 reads no other)");
    }
    Expect(v.is_number_integer(), at, type, v);
    if (v.is_number_unsigned() && v.get<uint64_t>() > uint64_t(std::numeric_limits<int64_t>::max()))
      Fail(at, "is " + v.dump() + ", past a 64-bit integer's range");
  }
  // A JSON integer in [lo, hi].
  std::optional<int64_t> Integer(const Json& o, const std::string& at, const char* key, int64_t lo = 0,
                                 int64_t hi = std::numeric_limits<int64_t>::max(),
                                 bool required = false) const {
    const Json* v = Member(o, at, key, required);
    if (!v) return std::nullopt;
    ExpectInteger(*v, At(at, key), "an integer");
    const int64_t x = v->get<int64_t>();
    if (x < lo || x > hi)
      Fail(At(at, key),
           "is " + v->dump() + ", outside the glTF 2.0 schema's range [" + std::to_string(lo) + ", " +
               (hi == std::numeric_limits<int64_t>::max() ? std::string("inf)") : std::to_string(hi) + "]"));
    return x;
  }
  // glTF's enumerations are open: the schema admits any integer or string beside the listed values, for later
  // versions, and the Khronos validator only warns of an unknown one. So they are type-checked only, and an
  // unknown value is refused where the simulator needs it (an accessor's format where a mesh reads it, a
  // primitive's mode, whose range the schema closes, and a sparse accessor's index type, without which its
  // data cannot be read).
  std::optional<int64_t> Enum(const Json& o, const std::string& at, const char* key,
                              std::initializer_list<int64_t> values, bool required = false) const {
    const std::optional<int64_t> x = Integer(o, at, key, std::numeric_limits<int64_t>::min(),
                                             std::numeric_limits<int64_t>::max(), required);
    if (!x) return x;
    std::vector<std::string> allowed;
    for (int64_t v : values) {
      if (v == *x) return x;
      allowed.push_back(std::to_string(v));
    }
    Fail(At(at, key), "is " + std::to_string(*x) + ", not one of the values glTF 2.0 allows (" +
                          Joined(allowed, ", ") + ")");
  }
  size_t Count(const char* array) const {
    const auto it = doc_.find(array);
    return it != doc_.end() && it->is_array() ? it->size() : 0;
  }
  void Refers(const Json& v, const std::string& at, const char* array) const {
    ExpectInteger(v, at, "an index (an integer)");
    if (v.get<int64_t>() < 0)
      Fail(at, "is " + v.dump() + ": an index must not be negative" + kSchema);
    if (v.get<uint64_t>() >= Count(array))
      Fail(at, "is " + v.dump() + ", past the end of /" + array + " (" + std::to_string(Count(array)) +
                   " elements)");
  }
  // An index into the document's top-level array `array`.
  std::optional<size_t> Index(const Json& o, const std::string& at, const char* key, const char* array,
                              bool required = false) const {
    const Json* v = Member(o, at, key, required);
    if (!v) return std::nullopt;
    Refers(*v, At(at, key), array);
    return v->get<size_t>();
  }
  // An array of at least one element.
  const Json* Array(const Json& o, const std::string& at, const char* key, bool required = false) const {
    const Json* v = Member(o, at, key, required);
    if (!v) return nullptr;
    Expect(v->is_array(), At(at, key), "an array", *v);
    if (v->empty()) Fail(At(at, key), "must not be empty" + kSchema);
    return v;
  }
  // An array of numbers, `length` long (any length from 1 when 0), each finite and in [lo, hi].
  const Json* Numbers(const Json& o, const std::string& at, const char* key, size_t length, double lo = -kInf,
                      double hi = kInf, bool required = false) const {
    const Json* v = Member(o, at, key, required);
    if (!v) return nullptr;
    Expect(v->is_array(), At(at, key), "an array of numbers", *v);
    if (length ? v->size() != length : v->empty())
      Fail(At(at, key), "has " + std::to_string(v->size()) + " elements, not " +
                            (length ? std::to_string(length) : std::string("at least 1")) + kSchema);
    for (size_t k = 0; k < v->size(); ++k) {
      Expect((*v)[k].is_number(), At(At(at, key), k), "a number", (*v)[k]);
      InRange((*v)[k], At(At(at, key), k), lo, hi, false);
    }
    return v;
  }
  // An array of distinct indices into `array`.
  const Json* Indices(const Json& o, const std::string& at, const char* key, const char* array,
                      bool required = false) const {
    const Json* v = Array(o, at, key, required);
    if (!v) return nullptr;
    std::set<uint64_t> seen;
    for (size_t k = 0; k < v->size(); ++k) {
      Refers((*v)[k], At(At(at, key), k), array);
      if (!seen.insert((*v)[k].get<uint64_t>()).second)
        Fail(At(At(at, key), k), "repeats " + (*v)[k].dump() + kSchema);
    }
    return v;
  }
  // Every element of the array o[key] an object, checked by `check`.
  void Objects(const Json& o, const std::string& at, const char* key,
               void (Schema::*check)(const Json&, const std::string&), bool required = false) {
    const Json* v = Array(o, at, key, required);
    if (!v) return;
    for (size_t i = 0; i < v->size(); ++i) {
      Expect((*v)[i].is_object(), At(At(at, key), i), "an object", (*v)[i]);
      (this->*check)((*v)[i], At(At(at, key), i));
    }
  }
  // What every glTF object may hold: a name, extensions (each an object, noted for the extensionsUsed check)
  // and extras, which the specification lets be anything but says should be an object, and Assimp 5.2 refuses
  // when it is not: refused here with that said.
  void Common(const Json& o, const std::string& at) {
    String(o, at, "name");
    if (const Json* x = Member(o, at, "extras", false); x && !x->is_object())
      Fail(At(at, "extras"), "is " + Shown(*x) +
                                 ": glTF 2.0 says extras should be an object, and Assimp 5.2 reads " +
                                 "no other");
    if (const Json* e = Object(o, at, "extensions")) {
      for (const auto& [name, value] : e->items()) {
        Expect(value.is_object(), At(At(at, "extensions"), name), "an object", value);
        extensionUses_.emplace_back(name, At(At(at, "extensions"), name));
      }
    }
  }
  // The object of extension `name` in o's extensions, or nullptr.
  const Json* Extension(const Json& o, const char* name) const {
    const auto e = o.find("extensions");
    if (e == o.end() || !e->is_object()) return nullptr;
    const auto x = e->find(name);
    return x != e->end() && x->is_object() ? &*x : nullptr;
  }

  // ---- the document's top level ----

  // asset.version "major.minor" with major 2; minVersion, when given, at most 2.0: an asset that needs a
  // later version must not load in a 2.0 reader (Khronos' glTF-Asset-Generator, Compatibility 04).
  void CheckAsset() {
    const Json* asset = Object(doc_, "", "asset", true);
    const std::string at = "/asset";
    Common(*asset, at);
    String(*asset, at, "copyright");
    String(*asset, at, "generator");
    auto version = [&](const char* key) -> std::optional<std::pair<uint64_t, uint64_t>> {
      const Json* v = String(*asset, at, key, std::string(key) == "version");
      if (!v) return std::nullopt;
      const std::string s = v->get<std::string>();
      const size_t dot = s.find('.');
      auto digits = [](const std::string& d) {
        return !d.empty() && d.size() < 10 && d.find_first_not_of("0123456789") == std::string::npos;
      };
      if (dot == std::string::npos || !digits(s.substr(0, dot)) || !digits(s.substr(dot + 1)))
        Fail(At(at, key), "is " + Shown(*v) + ", not of the form \"major.minor\"" + kSchema);
      return std::make_pair(std::stoull(s.substr(0, dot)), std::stoull(s.substr(dot + 1)));
    };
    const auto v = version("version");
    if (v->first != 2)
      Fail(At(at, "version"), "is \"" + (*asset)["version"].get<std::string>() +
                                  "\": only glTF 2.x is read (glTF " + std::to_string(v->first) +
                                  " is another format)");
    if (const auto m = version("minVersion")) {
      if (*m > *v) Fail(At(at, "minVersion"), "is greater than the asset's version");
      if (*m > std::make_pair(uint64_t(2), uint64_t(0)))
        Fail(At(at, "minVersion"), "is " + (*asset)["minVersion"].dump() +
                                       ": the asset needs a reader of that glTF " +
                                       "version, and this one reads glTF 2.0");
    }
  }

  void CheckExtensionLists() {
    for (const char* key : {"extensionsUsed", "extensionsRequired"}) {
      const Json* v = Array(doc_, "", key);
      if (!v) continue;
      std::set<std::string> seen;
      for (size_t k = 0; k < v->size(); ++k) {
        Expect((*v)[k].is_string(), At(At("", key), k), "a string", (*v)[k]);
        if (!seen.insert((*v)[k].get<std::string>()).second)
          Fail(At(At("", key), k), "repeats " + Shown((*v)[k]) + kSchema);
      }
      (std::string(key) == "extensionsUsed" ? used_ : required_) = seen;
    }
    const Json* required = Member(doc_, "", "extensionsRequired", false);
    for (size_t k = 0; required && k < required->size(); ++k) {
      const std::string name = (*required)[k].get<std::string>();
      const std::string at = At("/extensionsRequired", k);
      if (!used_.count(name)) Fail(at, "is '" + name + "', which extensionsUsed does not list (glTF 2.0)");
      if (!kReadableRequired.count(name))
        Fail(at, "is '" + name +
                     "', an extension the simulator does not read, and a reader that does not support a "
                     "required extension must refuse the asset (glTF 2.0, \"Specifying Extensions\")");
    }
  }

  // Every extension object an object holds is listed in extensionsUsed (the Khronos validator's
  // UNDECLARED_EXTENSION), and those the simulator reads sit where their specifications put them (its
  // UNEXPECTED_EXTENSION_OBJECT): a texture transform in a textureInfo (a "...Texture" property, also inside
  // another extension), emissive strength in a material, Draco in a mesh primitive. Checked last, so that a wrong
  // value inside an extension is named first.
  void CheckExtensionsUsed() const {
    for (const auto& [name, at] : extensionUses_) {
      if (!used_.count(name)) Fail(at, "is an extension that extensionsUsed does not list (glTF 2.0)");
      const std::string holder = at.substr(0, at.size() - name.size() - std::string("/extensions/").size());
      const std::string key = holder.substr(holder.rfind('/') + 1);
      const auto depth = std::count(at.begin(), at.end(), '/');
      const bool placed =
          name == "KHR_texture_transform" ? key.size() > 7 && key.compare(key.size() - 7, 7, "Texture") == 0
          : name == "KHR_materials_emissive_strength" ? at.rfind("/materials/", 0) == 0 && depth == 4
          : name == "KHR_draco_mesh_compression"
              ? at.rfind("/meshes/", 0) == 0 && depth == 6 && at.find("/primitives/") != std::string::npos
              : true;
      if (!placed) Fail(at, "is not where its specification puts it (in a " +
                                std::string(name == "KHR_texture_transform" ? "textureInfo"
                                            : name == "KHR_draco_mesh_compression" ? "mesh primitive"
                                                                                   : "material") +
                                ")");
    }
  }

  // ---- one object of each kind (glTF 2.0 §5, the JSON schema) ----

  void Accessor(const Json& a, const std::string& at) {
    Common(a, at);
    const auto view = Index(a, at, "bufferView", "bufferViews");
    const auto offset = Integer(a, at, "byteOffset");
    if (offset && !view) Fail(At(at, "byteOffset"), "is given without a bufferView" + kSchema);
    // componentType and type are open enumerations like glTF's others: an accessor of an unknown one is
    // refused only where a mesh reads it (CheckAttributeFormat).
    const auto type = Integer(a, at, "componentType", std::numeric_limits<int64_t>::min(),
                              std::numeric_limits<int64_t>::max(), true);
    Bool(a, at, "normalized");
    if (a.value("normalized", false) && (*type == 5125 || *type == 5126))
      Fail(At(at, "normalized"), "is true for a componentType of " + std::to_string(*type) +
                                     ": only 8- and 16-bit integers can be normalized (glTF 2.0 §3.6.2.2)");
    Integer(a, at, "count", 1, std::numeric_limits<int64_t>::max(), true);
    const size_t components = Components(String(a, at, "type", true)->get<std::string>());
    Numbers(a, at, "max", components);
    Numbers(a, at, "min", components);
    if (offset && KnownComponentType(*type) && *offset % static_cast<int64_t>(ComponentBytes(*type)) != 0)
      Fail(At(at, "byteOffset"), "is " + std::to_string(*offset) + ", not a multiple of its component's " +
                                     std::to_string(ComponentBytes(*type)) + " bytes (glTF 2.0 §3.6.2.4)");
    if (const Json* s = Object(a, at, "sparse")) {
      const std::string sat = At(at, "sparse");
      Common(*s, sat);
      const auto count = Integer(*s, sat, "count", 1, std::numeric_limits<int64_t>::max(), true);
      if (*count > a["count"].get<int64_t>())
        Fail(At(sat, "count"), "is " + std::to_string(*count) + ", more than the accessor's " +
                                   a["count"].dump() + " elements (glTF 2.0 §3.6.2.3)");
      const Json* indices = Object(*s, sat, "indices", true);
      Common(*indices, At(sat, "indices"));
      Index(*indices, At(sat, "indices"), "bufferView", "bufferViews", true);
      Integer(*indices, At(sat, "indices"), "byteOffset");
      Enum(*indices, At(sat, "indices"), "componentType", {5121, 5123, 5125}, true);
      const Json* values = Object(*s, sat, "values", true);
      Common(*values, At(sat, "values"));
      Index(*values, At(sat, "values"), "bufferView", "bufferViews", true);
      Integer(*values, At(sat, "values"), "byteOffset");
    }
  }

  void Animation(const Json& a, const std::string& at) {
    Common(a, at);
    Objects(a, at, "samplers", &Schema::AnimationSampler, true);
    const size_t samplers = a["samplers"].size();
    const Json* channels = Array(a, at, "channels", true);
    for (size_t c = 0; c < channels->size(); ++c) {
      const Json& ch = (*channels)[c];
      const std::string cat = At(At(at, "channels"), c);
      Expect(ch.is_object(), cat, "an object", ch);
      Common(ch, cat);
      Integer(ch, cat, "sampler", 0, static_cast<int64_t>(samplers) - 1, true);
      const Json* target = Object(ch, cat, "target", true);
      Common(*target, At(cat, "target"));
      Index(*target, At(cat, "target"), "node", "nodes");
      String(*target, At(cat, "target"), "path", true);
    }
  }
  void AnimationSampler(const Json& s, const std::string& at) {
    Common(s, at);
    Index(s, at, "input", "accessors", true);
    String(s, at, "interpolation");
    Index(s, at, "output", "accessors", true);
  }

  void Buffer(const Json& b, const std::string& at) {
    Common(b, at);
    String(b, at, "uri");
    Integer(b, at, "byteLength", 1, std::numeric_limits<int64_t>::max(), true);
  }

  void BufferView(const Json& v, const std::string& at) {
    Common(v, at);
    Index(v, at, "buffer", "buffers", true);
    Integer(v, at, "byteOffset");
    const auto length = Integer(v, at, "byteLength", 1, std::numeric_limits<int64_t>::max(), true);
    if (const auto stride = Integer(v, at, "byteStride", 4, 252)) {
      if (*stride % 4 != 0)
        Fail(At(at, "byteStride"), "is " + std::to_string(*stride) + ", not a multiple of 4" + kSchema);
      if (*stride > *length)
        Fail(At(at, "byteStride"), "is " + std::to_string(*stride) + ", more than the view's byteLength " +
                                       std::to_string(*length));
    }
    Integer(v, at, "target", std::numeric_limits<int64_t>::min());
  }

  void Camera(const Json& c, const std::string& at) {
    Common(c, at);
    const std::string type = String(c, at, "type", true)->get<std::string>();
    const Json* ortho = Object(c, at, "orthographic", type == "orthographic");
    const Json* persp = Object(c, at, "perspective", type == "perspective");
    if (ortho && persp) Fail(at, "must not have both 'orthographic' and 'perspective'" + kSchema);
    if (ortho) {
      const std::string o = At(at, "orthographic");
      Common(*ortho, o);
      const double xmag = *Number(*ortho, o, "xmag", -kInf, kInf, true);
      const double ymag = *Number(*ortho, o, "ymag", -kInf, kInf, true);
      const double zfar = *Number(*ortho, o, "zfar", 0.0, kInf, true, true);
      const double znear = *Number(*ortho, o, "znear", 0.0, kInf, true);
      if (xmag == 0.0 || ymag == 0.0) Fail(o, "has a zero xmag or ymag (glTF 2.0 §5.13)");
      if (!(zfar > znear)) Fail(At(o, "zfar"), "must be greater than znear (glTF 2.0 §5.13)");
    }
    if (persp) {
      const std::string p = At(at, "perspective");
      Common(*persp, p);
      Number(*persp, p, "aspectRatio", 0.0, kInf, false, true);
      Number(*persp, p, "yfov", 0.0, kInf, true, true);
      const auto zfar = Number(*persp, p, "zfar", 0.0, kInf, false, true);
      const double znear = *Number(*persp, p, "znear", 0.0, kInf, true, true);
      if (zfar && !(*zfar > znear)) Fail(At(p, "zfar"), "must be greater than znear (glTF 2.0 §5.14)");
    }
  }

  void Image(const Json& i, const std::string& at) {
    Common(i, at);
    const Json* uri = String(i, at, "uri");
    String(i, at, "mimeType");
    const auto view = Index(i, at, "bufferView", "bufferViews");
    if (bool(uri) == bool(view)) Fail(at, "must have exactly one of 'uri' and 'bufferView'" + kSchema);
    if (view && !i.contains("mimeType")) Fail(at, "must have 'mimeType' beside its 'bufferView'" + kSchema);
  }

  // A textureInfo (glTF 2.0 §5.22, with normalTextureInfo's scale and occlusionTextureInfo's strength), and
  // the UV set it reads, noted for its material (KHR_texture_transform's texCoord overrides the
  // textureInfo's).
  void TextureInfo(const Json& o, const std::string& at, const char* key, int64_t& maxTexCoord) {
    const Json* t = Object(o, at, key);
    if (!t) return;
    const std::string tat = At(at, key);
    Common(*t, tat);
    Index(*t, tat, "index", "textures", true);
    int64_t set = Integer(*t, tat, "texCoord").value_or(0);
    if (std::string(key) == "normalTexture") Number(*t, tat, "scale");
    if (std::string(key) == "occlusionTexture") Number(*t, tat, "strength", 0.0, 1.0);
    if (const Json* x = Extension(*t, "KHR_texture_transform")) {
      const std::string xat = At(At(tat, "extensions"), "KHR_texture_transform");
      Common(*x, xat);
      Numbers(*x, xat, "offset", 2);
      Number(*x, xat, "rotation");
      Numbers(*x, xat, "scale", 2);
      // The transform's texCoord overrides the textureInfo's for reading, but the validator asks for both sets.
      if (const auto s = Integer(*x, xat, "texCoord")) maxTexCoord = std::max(maxTexCoord, *s);
    }
    maxTexCoord = std::max(maxTexCoord, set);
  }

  void Material(const Json& m, const std::string& at) {
    Common(m, at);
    int64_t maxTexCoord = -1;
    if (const Json* pbr = Object(m, at, "pbrMetallicRoughness")) {
      const std::string p = At(at, "pbrMetallicRoughness");
      Common(*pbr, p);
      Numbers(*pbr, p, "baseColorFactor", 4, 0.0, 1.0);
      TextureInfo(*pbr, p, "baseColorTexture", maxTexCoord);
      Number(*pbr, p, "metallicFactor", 0.0, 1.0);
      Number(*pbr, p, "roughnessFactor", 0.0, 1.0);
      TextureInfo(*pbr, p, "metallicRoughnessTexture", maxTexCoord);
    }
    TextureInfo(m, at, "normalTexture", maxTexCoord);
    TextureInfo(m, at, "occlusionTexture", maxTexCoord);
    TextureInfo(m, at, "emissiveTexture", maxTexCoord);
    Numbers(m, at, "emissiveFactor", 3, 0.0, 1.0);
    String(m, at, "alphaMode");
    Number(m, at, "alphaCutoff", 0.0);
    Bool(m, at, "doubleSided");
    if (const Json* s = Extension(m, "KHR_materials_emissive_strength")) {
      const std::string sat = At(At(at, "extensions"), "KHR_materials_emissive_strength");
      Common(*s, sat);
      Number(*s, sat, "emissiveStrength", 0.0);
    }
    materialTexCoords_.push_back(maxTexCoord);
  }

  void Mesh(const Json& m, const std::string& at) {
    Common(m, at);
    Objects(m, at, "primitives", &Schema::Primitive, true);
    Numbers(m, at, "weights", 0);
  }
  void Primitive(const Json& p, const std::string& at) {
    Common(p, at);
    const Json* attributes = Object(p, at, "attributes", true);
    if (attributes->empty()) Fail(At(at, "attributes"), "must not be empty" + kSchema);
    for (const auto& [name, value] : attributes->items())
      Refers(value, At(At(at, "attributes"), name), "accessors");
    Index(p, at, "indices", "accessors");
    Index(p, at, "material", "materials");
    Integer(p, at, "mode", 0, 6);
    if (const Json* targets = Array(p, at, "targets")) {
      for (size_t t = 0; t < targets->size(); ++t) {
        Expect((*targets)[t].is_object(), At(At(at, "targets"), t), "an object", (*targets)[t]);
        for (const auto& [name, value] : (*targets)[t].items())
          Refers(value, At(At(At(at, "targets"), t), name), "accessors");
      }
    }
    if (const Json* draco = Extension(p, "KHR_draco_mesh_compression")) {
      const std::string dat = At(At(at, "extensions"), "KHR_draco_mesh_compression");
      Index(*draco, dat, "bufferView", "bufferViews", true);
      const Json* a = Object(*draco, dat, "attributes", true);
      for (const auto& [name, value] : a->items())
        Expect(value.is_number_integer() && value.get<int64_t>() >= 0, At(At(dat, "attributes"), name),
               "a non-negative integer", value);
    }
    primitives_.push_back({&p, at});
  }

  void Node(const Json& n, const std::string& at) {
    Common(n, at);
    Index(n, at, "camera", "cameras");
    Indices(n, at, "children", "nodes");
    Index(n, at, "skin", "skins");
    Index(n, at, "mesh", "meshes");
    if (n.contains("skin") && !n.contains("mesh")) Fail(At(at, "skin"), "is given without a mesh" + kSchema);
    const Json* matrix = Numbers(n, at, "matrix", 16);
    const Json* rotation = Numbers(n, at, "rotation", 4, -1.0, 1.0);
    const Json* scale = Numbers(n, at, "scale", 3);
    const Json* translation = Numbers(n, at, "translation", 3);
    Numbers(n, at, "weights", 0);
    if (n.contains("weights") && !n.contains("mesh"))
      Fail(At(at, "weights"), "is given without a mesh" + kSchema);
    if (matrix && (rotation || scale || translation))
      Fail(at, "has both a matrix and translation, rotation or scale (glTF 2.0 §5.25: one or the other)");
    if (rotation) {
      double q = 0.0;
      for (const Json& c : *rotation) q += c.get<double>() * c.get<double>();
      if (std::fabs(std::sqrt(q) - 1.0) > kUnitQuaternionTolerance)
        Fail(At(at, "rotation"), "has length " + Json(std::sqrt(q)).dump() +
                                     ", not a unit quaternion (glTF 2.0 " +
                                     "§5.25); it would scale the mesh");
    }
  }

  void Sampler(const Json& s, const std::string& at) {
    Common(s, at);
    // An unknown wrap mode reads as the default, REPEAT (sim/assets/asset_import.cpp WrapOf).
    for (const char* key : {"magFilter", "minFilter", "wrapS", "wrapT"})
      Integer(s, at, key, std::numeric_limits<int64_t>::min());
  }

  void Scene(const Json& s, const std::string& at) {
    Common(s, at);
    Indices(s, at, "nodes", "nodes");
  }

  void Skin(const Json& s, const std::string& at) {
    Common(s, at);
    Index(s, at, "inverseBindMatrices", "accessors");
    Index(s, at, "skeleton", "nodes");
    Indices(s, at, "joints", "nodes", true);
  }

  void Texture(const Json& t, const std::string& at) {
    Common(t, at);
    Index(t, at, "sampler", "samplers");
    Index(t, at, "source", "images");
  }

  // ---- across objects ----

  // A mesh primitive's attributes (glTF 2.0 §3.7.2.1): names of the specification (or application-specific,
  // beginning with '_'), each of its accessor formats, all of one count; indexed sets TEXCOORD_0..n-1 and
  // COLOR_0.. n-1 without gaps, as many JOINTS_n as WEIGHTS_n; indices scalar unsigned integers in a view
  // without byteStride; a TEXCOORD_n for every texture its material reads (Khronos'
  // MESH_PRIMITIVE_TOO_FEW_TEXCOORDS).
  void CheckPrimitives() const {
    static const Json kNone = Json::array();
    const Json& accessors = doc_.contains("accessors") ? doc_["accessors"] : kNone;
    for (const auto& [primitive, at] : primitives_) {
      const Json& p = *primitive;
      const bool draco = Extension(p, "KHR_draco_mesh_compression") != nullptr;  // its accessors have no views
      std::optional<uint64_t> count;
      std::map<std::string, int>
          sets;  // highest n + 1 and number of TEXCOORD_n, COLOR_n, JOINTS_n, WEIGHTS_n
      std::map<std::string, int> numbered;
      for (const auto& [name, index] : p["attributes"].items()) {
        const std::string aat = At(At(at, "attributes"), name);
        const Json& a = accessors[index.get<size_t>()];
        const std::string semantic = Semantic(name, aat, sets, numbered);
        if (!semantic.empty()) CheckAttributeFormat(semantic, a, aat, index.get<size_t>());
        if (!draco) NeedsData(a, aat, index.get<size_t>());
        if (count && a["count"].get<uint64_t>() != *count)
          Fail(aat, "has " + a["count"].dump() + " elements where the primitive's other attributes have " +
                        std::to_string(*count) + " (glTF 2.0 §3.7.2.1)");
        count = a["count"].get<uint64_t>();
      }
      for (const char* set : {"TEXCOORD", "COLOR"})
        if (sets[set] != numbered[set])
          Fail(At(at, "attributes"), std::string("numbers its ") + set +
                                         "_n sets with a gap: they must run from " + set +
                                         "_0 without one (glTF 2.0 §3.7.2.1)");
      if (numbered["JOINTS"] != numbered["WEIGHTS"])
        Fail(At(at, "attributes"), "has " + std::to_string(numbered["JOINTS"]) + " JOINTS_n and " +
                                       std::to_string(numbered["WEIGHTS"]) +
                                       " WEIGHTS_n (glTF 2.0 §3.7.3.3)");
      if (p.contains("indices")) {
        const Json& a = accessors[p["indices"].get<size_t>()];
        if (!draco) NeedsData(a, At(at, "indices"), p["indices"].get<size_t>());
        const int64_t type = a["componentType"].get<int64_t>();
        if (a["type"] != "SCALAR" || !(type == 5121 || type == 5123 || type == 5125) ||
            a.value("normalized", false))
          Fail(At(at, "indices"), "names accessor " + p["indices"].dump() +
                                      ", which is not of unsigned bytes, shorts " +
                                      "or ints as SCALAR (glTF 2.0 §3.7.2.1)");
        if (a.contains("bufferView") &&
            doc_["bufferViews"][a["bufferView"].get<size_t>()].contains("byteStride"))
          Fail(At(at, "indices"), "names accessor " + p["indices"].dump() +
                                      ", whose buffer view has a byteStride " +
                                      "(glTF 2.0 §3.6.2.4: only vertex attributes may)");
      }
      if (p.contains("material")) {
        const int64_t needs = materialTexCoords_[p["material"].get<size_t>()];
        if (needs >= sets["TEXCOORD"])
          Fail(at, "has material " + p["material"].dump() + ", one of whose textures reads TEXCOORD_" +
                       std::to_string(needs) + ", which the primitive does not have");
      }
    }
  }
  // A mesh's accessor without a bufferView or sparse values is all zeros (§3.6.2.1): valid, but Assimp 5.2 reads
  // no mesh data from one ("data is null"), so it is refused here with that said.
  void NeedsData(const Json& a, const std::string& at, size_t index) const {
    if (!a.contains("bufferView") && !a.contains("sparse"))
      Fail(at, "names accessor " + std::to_string(index) + ", which has neither a bufferView nor sparse values " +
                   "(all zeros): Assimp 5.2 reads no mesh data from one");
  }
  // The semantic of attribute `name` ("TEXCOORD" for TEXCOORD_3), counting the indexed sets; "" for an
  // application-specific one. Refuses a name the specification does not define.
  std::string Semantic(const std::string& name, const std::string& at, std::map<std::string, int>& sets,
                       std::map<std::string, int>& numbered) const {
    if (!name.empty() && name[0] == '_') return "";
    if (name == "POSITION" || name == "NORMAL" || name == "TANGENT") return name;
    const size_t underscore = name.find('_');
    const std::string base = name.substr(0, underscore);
    const std::string n = underscore == std::string::npos ? "" : name.substr(underscore + 1);
    const bool number = !n.empty() && n.size() < 7 &&
                        n.find_first_not_of("0123456789") == std::string::npos && (n == "0" || n[0] != '0');
    if (!number || !(base == "TEXCOORD" || base == "COLOR" || base == "JOINTS" || base == "WEIGHTS"))
      Fail(
          at,
          "is not an attribute name of glTF 2.0 (POSITION, NORMAL, TANGENT, TEXCOORD_n, COLOR_n, JOINTS_n, " +
              std::string("WEIGHTS_n, or one beginning with '_'; §3.7.2.1)"));
    sets[base] = std::max(sets[base], std::stoi(n) + 1);
    ++numbered[base];
    return base;
  }
  // The accessor formats glTF 2.0 §3.7.2.1 allows each attribute (without KHR_mesh_quantization, which the
  // simulator does not read).
  void CheckAttributeFormat(const std::string& semantic, const Json& a, const std::string& at,
                            size_t index) const {
    const std::string type = a["type"].get<std::string>();
    const int64_t component = a["componentType"].get<int64_t>();
    const bool normalized = a.value("normalized", false);
    const bool isFloat = component == 5126;
    const bool unorm = (component == 5121 || component == 5123) && normalized;
    bool ok = false;
    if (semantic == "POSITION" || semantic == "NORMAL")
      ok = type == "VEC3" && isFloat;
    else if (semantic == "TANGENT")
      ok = type == "VEC4" && isFloat;
    else if (semantic == "TEXCOORD")
      ok = type == "VEC2" && (isFloat || unorm);
    else if (semantic == "COLOR")
      ok = (type == "VEC3" || type == "VEC4") && (isFloat || unorm);
    else if (semantic == "JOINTS")
      ok = type == "VEC4" && (component == 5121 || component == 5123) && !normalized;
    else if (semantic == "WEIGHTS")
      ok = type == "VEC4" && (isFloat || unorm);
    if (!ok)
      Fail(at, "names accessor " + std::to_string(index) + " of " + type + " with componentType " +
                   std::to_string(component) + (normalized ? " normalized" : "") +
                   ", not a format glTF 2.0 §3.7.2.1 " + "allows " + semantic);
  }

  // The node hierarchy is a forest (glTF 2.0 §3.5.3): no node the child of two, no loop, a scene's nodes
  // roots.
  void CheckHierarchy() const {
    const size_t n = Count("nodes");
    std::vector<int64_t> parent(n, -1);
    for (size_t i = 0; i < n; ++i) {
      const Json& node = doc_["nodes"][i];
      if (!node.contains("children")) continue;
      for (const Json& c : node["children"]) {
        const size_t child = c.get<size_t>();
        if (parent[child] >= 0)
          Fail(At(At("/nodes", i), "children"), "names node " + std::to_string(child) +
                                                    ", already a child of node " +
                                                    std::to_string(parent[child]) + " (glTF 2.0 §3.5.3)");
        parent[child] = static_cast<int64_t>(i);
      }
    }
    // With one parent each, a loop is a walk up the parents that comes back to where it has been: each walk
    // marks its nodes and stops at a node an earlier walk marked (which ended at a root).
    std::vector<size_t> walk(n, 0);
    for (size_t i = 0; i < n; ++i) {
      for (int64_t k = static_cast<int64_t>(i); k >= 0; k = parent[k]) {
        if (walk[k] == i + 1)
          Fail(At("/nodes", static_cast<size_t>(k)),
               "is its own ancestor: the node hierarchy has a loop (glTF 2.0 "
               "§3.5.3)");
        if (walk[k] != 0) break;
        walk[k] = i + 1;
      }
    }
    for (size_t s = 0; s < Count("scenes"); ++s) {
      const Json& scene = doc_["scenes"][s];
      if (!scene.contains("nodes")) continue;
      for (size_t k = 0; k < scene["nodes"].size(); ++k)
        if (parent[scene["nodes"][k].get<size_t>()] >= 0)
          Fail(At(At(At("/scenes", s), "nodes"), k),
               "names node " + scene["nodes"][k].dump() + ", which is not a " +
                   "root: it is a child of node " + std::to_string(parent[scene["nodes"][k].get<size_t>()]) +
                   " (glTF 2.0 §3.5.2)");
    }
  }

  const Json& doc_;
  const std::string& path_;
  std::set<std::string> used_, required_;
  std::vector<std::pair<std::string, std::string>> extensionUses_;  // each extension object: name, JSON pointer
  std::vector<int64_t> materialTexCoords_;  // per material: the highest UV set a texture reads, or -1
  std::vector<std::pair<const Json*, std::string>> primitives_;  // every mesh primitive with its JSON pointer
};

}  // namespace

void CheckGltfSchema(const nlohmann::json& doc, const std::string& path) {
  Schema(doc, path).Check();
}

}  // namespace restir
