#include "sim/util/json_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>

#include "sim/util/input_error.h"
#include "sim/util/text.h"

namespace restir {

namespace {

// Parses, turning nlohmann's exceptions into one located message.
Json Parse(const std::string& text, const std::string& file) {
  try {
    return Json::parse(text);
  } catch (const Json::parse_error& e) {
    // e.byte counts the characters read, the offending one included.
    size_t offset = e.byte > 0 ? e.byte - 1 : 0;
    std::string what = e.what();
    if (what.find("invalid literal") != std::string::npos) {
      // The lexer stops after reading part of a bad literal ("tru}"): point at where the literal starts.
      auto literalChar = [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '+' || c == '-' || c == '.';
      };
      while (offset > 0 && offset <= text.size() && literalChar(text[offset - 1])) --offset;
    }
    const SourcePos pos = PosFromOffset(text, offset);
    size_t cut = what.find("column ");
    cut = cut == std::string::npos ? std::string::npos : what.find(": ", cut);
    if (cut != std::string::npos) what = what.substr(cut + 2);
    throw InputError(OneLine(file + ":" + std::to_string(pos.line) + ":" + std::to_string(pos.column) +
                             ": error: invalid JSON: " + what));
  } catch (const Json::exception& e) {
    // Number overflow (1e999) is nlohmann's out_of_range, without a position: find the literal in the text.
    std::string what = e.what();
    const size_t q1 = what.find('\'');
    const size_t q2 = q1 == std::string::npos ? q1 : what.find('\'', q1 + 1);
    SourcePos pos;
    if (q2 != std::string::npos) pos = PosFromOffset(text, text.find(what.substr(q1 + 1, q2 - q1 - 1)));
    const size_t bracket = what.find("] ");
    if (bracket != std::string::npos) what = what.substr(bracket + 2);
    throw InputError(OneLine(file + ":" + std::to_string(pos.line) + ":" + std::to_string(pos.column) +
                             ": error: invalid JSON: " + what));
  }
}

}  // namespace

std::string JsonTypeName(const Json& v) {
  switch (v.type()) {
    case Json::value_t::null: return "null";
    case Json::value_t::object: return "object";
    case Json::value_t::array: return "array";
    case Json::value_t::string: return "string";
    case Json::value_t::boolean: return "boolean";
    case Json::value_t::binary: return "binary";
    case Json::value_t::discarded: return "nothing";
    default: return "number";
  }
}

JsonReader::JsonReader(std::string file, std::string text)
    : file_(std::move(file)), text_(std::move(text)), root_(Parse(text_, file_)), locator_(text_) {
  SourcePos pos;
  if (locator_.TooDeep(pos)) {
    throw InputError(file_ + ":" + std::to_string(pos.line) + ":" + std::to_string(pos.column) +
                     ": error: JSON nests deeper than " + std::to_string(JsonLocator::kMaxDepth) + " levels");
  }
  const std::string& dup = locator_.DuplicateKeyPointer();
  if (!dup.empty()) FailKey(dup, "duplicate key '" + dup.substr(dup.rfind('/') + 1) + "'");
}

void JsonReader::FailAt(const SourcePos& pos, const std::string& pointer, const std::string& message) const {
  throw InputError(OneLine(file_ + ":" + std::to_string(pos.line) + ":" + std::to_string(pos.column) +
                           ": error at " + (pointer.empty() ? std::string("(top level)") : pointer) + ": " +
                           message));
}

void JsonReader::Fail(const std::string& pointer, const std::string& message) const {
  FailAt(locator_.ValuePos(pointer), pointer, message);
}

void JsonReader::FailKey(const std::string& pointer, const std::string& message) const {
  FailAt(locator_.KeyPos(pointer), pointer, message);
}

const Json& JsonReader::AsObject(const Json& v, const std::string& p) const {
  if (!v.is_object()) Fail(p, "expected an object, got " + JsonTypeName(v));
  return v;
}

const Json& JsonReader::AsArray(const Json& v, const std::string& p, bool nonEmpty) const {
  if (!v.is_array()) Fail(p, "expected an array, got " + JsonTypeName(v));
  if (nonEmpty && v.empty()) Fail(p, "expected a non-empty array");
  return v;
}

void JsonReader::CheckKeys(const Json& obj, const std::string& p, const std::vector<std::string>& known) const {
  for (auto it = obj.begin(); it != obj.end(); ++it)
    if (std::find(known.begin(), known.end(), it.key()) == known.end())
      FailKey(PointerChild(p, it.key()), "unknown key '" + it.key() + "'" + Suggestion(it.key(), known));
}

const Json* JsonReader::Find(const Json& obj, const std::string& key) const {
  auto it = obj.find(key);
  return it == obj.end() ? nullptr : &*it;
}

const Json& JsonReader::Need(const Json& obj, const std::string& p, const std::string& key) const {
  const Json* v = Find(obj, key);
  if (!v) Fail(p, "missing required key '" + key + "'");
  return *v;
}

double JsonReader::Number(const Json& v, const std::string& p) const {
  if (!v.is_number()) Fail(p, "expected a number, got " + JsonTypeName(v));
  return v.get<double>();
}

float JsonReader::Float(const Json& v, const std::string& p) const { return Float(v, p, magnitudeLimit_, magnitudeWhat_); }

float JsonReader::Float(const Json& v, const std::string& p, double limit, const std::string& what) const {
  const float f = static_cast<float>(Number(v, p));
  if (!std::isfinite(f)) Fail(p, "number " + v.dump() + " is out of single-precision range");
  if (std::fabs(double(f)) > limit) {
    char text[32];
    std::snprintf(text, sizeof(text), "%g", limit);
    Fail(p, "number " + v.dump() + " is beyond the limit of " + text + " for " + what +
                " (products of such numbers must stay finite in single precision)");
  }
  return f;
}

int64_t JsonReader::Integer(const Json& v, const std::string& p, int64_t lo, int64_t hi,
                            const std::string& what) const {
  if (!v.is_number()) Fail(p, "expected an integer, got " + JsonTypeName(v));
  int64_t value = 0;
  if (v.is_number_integer()) {
    value = v.is_number_unsigned() ? static_cast<int64_t>(std::min<uint64_t>(v.get<uint64_t>(), INT64_MAX))
                                   : v.get<int64_t>();
  } else {
    const double d = v.get<double>();
    if (d != std::floor(d) || std::fabs(d) > 9e15) Fail(p, "expected an integer, got " + v.dump());
    value = static_cast<int64_t>(d);
  }
  if (value < lo || value > hi)
    Fail(p, what + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                std::to_string(value));
  return value;
}

std::string JsonReader::String(const Json& v, const std::string& p) const {
  if (!v.is_string()) Fail(p, "expected a string, got " + JsonTypeName(v));
  return v.get<std::string>();
}

std::string JsonReader::Name(const Json& v, const std::string& p) const {
  std::string s = String(v, p);
  if (s.empty()) Fail(p, "name must not be empty");
  return s;
}

Vec3 JsonReader::Vector(const Json& v, const std::string& p) const {
  if (!v.is_array() || v.size() != 3)
    Fail(p, "expected an array of 3 numbers, got " +
                (v.is_array() ? "an array of " + std::to_string(v.size()) : JsonTypeName(v)));
  return Vec3(Float(v[0], PointerChild(p, 0)), Float(v[1], PointerChild(p, 1)), Float(v[2], PointerChild(p, 2)));
}

size_t JsonReader::Choice(const Json& v, const std::string& p, const std::string& what,
                          const std::vector<std::string>& options) const {
  const std::string s = String(v, p);
  auto it = std::find(options.begin(), options.end(), s);
  if (it == options.end()) Fail(p, "unknown " + what + " '" + s + "'" + Suggestion(s, options));
  return static_cast<size_t>(it - options.begin());
}

}  // namespace restir
