// Reading a JSON input file with every error located (DESIGN §10): one message naming file:line:column and the
// JSON path, for sequence files and sweep files alike. JsonReader parses the text, refuses what nlohmann would
// silently accept (nesting deeper than JsonLocator::kMaxDepth, a key twice in one object) and offers typed
// accessors that check the value and name its position when it is wrong.
#pragma once

#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/math.h"
#include "sim/util/json_locator.h"

namespace restir {

using Json = nlohmann::json;

// "string", "array", ...: the JSON type of a value, for messages.
std::string JsonTypeName(const Json& v);

class JsonReader {
 public:
  // Parses `text` (read from `file`, which messages name). Throws InputError at the syntax error, at the first
  // too-deep container or at the second occurrence of a duplicate key.
  JsonReader(std::string file, std::string text);
  JsonReader(const JsonReader&) = delete;
  JsonReader& operator=(const JsonReader&) = delete;

  const Json& Root() const { return root_; }
  SourcePos Position(const std::string& pointer) const { return locator_.ValuePos(pointer); }
  const std::string& File() const { return file_; }
  const std::string& Text() const { return text_; }

  // Problem with the value at pointer.
  [[noreturn]] void Fail(const std::string& pointer, const std::string& message) const;
  // Problem with the key of the member at pointer (unknown or duplicate key).
  [[noreturn]] void FailKey(const std::string& pointer, const std::string& message) const;

  // Typed access. Each checks the JSON type and reports "expected ..., got ..." at the value.
  const Json& AsObject(const Json& v, const std::string& p) const;
  const Json& AsArray(const Json& v, const std::string& p, bool nonEmpty) const;
  // Every key of `obj` must be one of `known`: "unknown key 'x' (did you mean 'y'?)" or "(expected one of: ...)".
  void CheckKeys(const Json& obj, const std::string& p, const std::vector<std::string>& known) const;
  const Json* Find(const Json& obj, const std::string& key) const;
  const Json& Need(const Json& obj, const std::string& p, const std::string& key) const;
  double Number(const Json& v, const std::string& p) const;
  // A number that fits a float, within the magnitude limit (SetMagnitudeLimit).
  float Float(const Json& v, const std::string& p) const;
  // A number that fits a float, at most `limit` in magnitude (`what` names it in the message).
  float Float(const Json& v, const std::string& p, double limit, const std::string& what) const;
  // Every Float (hence every Vector) read from now on must be at most `limit` in magnitude; `what` names the
  // numbers in the message ("coordinates, sizes, angles and colours").
  void SetMagnitudeLimit(double limit, std::string what) {
    magnitudeLimit_ = limit;
    magnitudeWhat_ = std::move(what);
  }
  int64_t Integer(const Json& v, const std::string& p, int64_t lo, int64_t hi, const std::string& what) const;
  std::string String(const Json& v, const std::string& p) const;
  std::string Name(const Json& v, const std::string& p) const;  // a non-empty string
  Vec3 Vector(const Json& v, const std::string& p) const;       // [x, y, z], each a float
  // One of a closed set of strings; suggests the nearest on a typo.
  size_t Choice(const Json& v, const std::string& p, const std::string& what,
                const std::vector<std::string>& options) const;

 private:
  [[noreturn]] void FailAt(const SourcePos& pos, const std::string& pointer, const std::string& message) const;

  std::string file_;
  std::string text_;  // the locator keeps a reference to it
  double magnitudeLimit_ = INFINITY;
  std::string magnitudeWhat_;
  Json root_;
  JsonLocator locator_;
};

}  // namespace restir
