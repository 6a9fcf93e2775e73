// Source positions for JSON values. nlohmann::json keeps no positions after parsing, so semantic errors
// (a negative radius, an unknown key) could otherwise only name a JSON path. The locator scans the text once
// more with a minimal tokenizer and remembers where every value and every object key starts, indexed by its
// JSON pointer (RFC 6901: "/objects/3/shape/radius"), so every error can say file:line:column (DESIGN §10).
#pragma once

#include <cstddef>
#include <string>
#include <unordered_map>

namespace restir {

// 1-based line and column; columns count Unicode code points (UTF-8 continuation bytes do not advance), so
// they match what an editor shows for non-ASCII text.
struct SourcePos {
  int line = 1;
  int column = 1;
};

// Line and column of a byte offset into text (an offset past the end maps to just after the last character).
SourcePos PosFromOffset(const std::string& text, size_t offset);

// Appends one pointer token to a JSON pointer, escaping '~' and '/' (RFC 6901).
std::string PointerChild(const std::string& pointer, const std::string& key);
std::string PointerChild(const std::string& pointer, size_t index);

class JsonLocator {
 public:
  // text must be syntactically valid JSON (parse it with nlohmann first) and must outlive the locator. The
  // scan is iterative, so deeply nested input cannot overflow the stack.
  explicit JsonLocator(const std::string& text);

  // Where the value at pointer starts. A pointer that does not exist falls back to its nearest existing
  // ancestor, so an error about a missing key points at the object that lacks it.
  SourcePos ValuePos(const std::string& pointer) const;
  // Where the key of an object member starts (falls back to ValuePos for array elements and the root).
  SourcePos KeyPos(const std::string& pointer) const;

  // The first key that appears twice in one object (nlohmann silently keeps the last), or "" if none;
  // its pointer names the second occurrence.
  const std::string& DuplicateKeyPointer() const { return duplicateKey_; }

  // Containers nested deeper than this stop the scan: paths of every level would take memory quadratic in
  // the depth, and no sequence file needs more than a handful of levels.
  static constexpr size_t kMaxDepth = 64;
  // True when the text nests deeper than kMaxDepth; pos is where the first too-deep container starts.
  bool TooDeep(SourcePos& pos) const {
    if (tooDeepOffset_ == kNone) return false;
    pos = PosFromOffset(text_, tooDeepOffset_);
    return true;
  }

 private:
  std::unordered_map<std::string, size_t> valueOffsets_;
  std::unordered_map<std::string, size_t> keyOffsets_;
  std::string duplicateKey_;
  static constexpr size_t kNone = ~size_t(0);
  size_t tooDeepOffset_ = kNone;
  const std::string& text_;
};

}  // namespace restir
