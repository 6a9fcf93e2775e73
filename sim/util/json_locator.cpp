#include "sim/util/json_locator.h"

#include <cstdint>
#include <vector>

namespace restir {

SourcePos PosFromOffset(const std::string& text, size_t offset) {
  SourcePos pos;
  const size_t end = offset < text.size() ? offset : text.size();
  for (size_t i = 0; i < end; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c == '\n') {
      ++pos.line;
      pos.column = 1;
    } else if ((c & 0xC0) != 0x80) {  // count code points, not UTF-8 continuation bytes
      ++pos.column;
    }
  }
  return pos;
}

std::string PointerChild(const std::string& pointer, const std::string& key) {
  std::string out = pointer;
  out += '/';
  for (char c : key) {
    if (c == '~') {
      out += "~0";
    } else if (c == '/') {
      out += "~1";
    } else {
      out += c;
    }
  }
  return out;
}

std::string PointerChild(const std::string& pointer, size_t index) {
  return pointer + "/" + std::to_string(index);
}

namespace {

void AppendUtf8(std::string& out, uint32_t cp) {
  if (cp < 0x80) {
    out += static_cast<char>(cp);
  } else if (cp < 0x800) {
    out += static_cast<char>(0xC0 | (cp >> 6));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    out += static_cast<char>(0xE0 | (cp >> 12));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | (cp >> 18));
    out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  }
}

uint32_t Hex4(const std::string& s, size_t i) {
  uint32_t v = 0;
  for (size_t k = 0; k < 4 && i + k < s.size(); ++k) {
    const char c = s[i + k];
    v <<= 4;
    if (c >= '0' && c <= '9') {
      v |= static_cast<uint32_t>(c - '0');
    } else if (c >= 'a' && c <= 'f') {
      v |= static_cast<uint32_t>(c - 'a' + 10);
    } else if (c >= 'A' && c <= 'F') {
      v |= static_cast<uint32_t>(c - 'A' + 10);
    }
  }
  return v;
}

// Decodes the string literal starting at s[i] == '"' (keys must match nlohmann's decoded keys); returns the
// offset just past the closing quote.
size_t ReadString(const std::string& s, size_t i, std::string* decoded) {
  ++i;
  while (i < s.size() && s[i] != '"') {
    if (s[i] == '\\' && i + 1 < s.size()) {
      const char e = s[i + 1];
      if (e == 'u') {
        uint32_t cp = Hex4(s, i + 2);
        i += 6;
        if (cp >= 0xD800 && cp < 0xDC00 && i + 1 < s.size() && s[i] == '\\' && s[i + 1] == 'u') {
          const uint32_t lo = Hex4(s, i + 2);
          cp = 0x10000 + ((cp - 0xD800) << 10) + (lo - 0xDC00);
          i += 6;
        }
        if (decoded) AppendUtf8(*decoded, cp);
        continue;
      }
      if (decoded) {
        switch (e) {
          case 'b':
            *decoded += '\b';
            break;
          case 'f':
            *decoded += '\f';
            break;
          case 'n':
            *decoded += '\n';
            break;
          case 'r':
            *decoded += '\r';
            break;
          case 't':
            *decoded += '\t';
            break;
          default:
            *decoded += e;
            break;  // \" \\ \/
        }
      }
      i += 2;
    } else {
      if (decoded) *decoded += s[i];
      ++i;
    }
  }
  return i + 1;
}

bool IsSpace(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

}  // namespace

JsonLocator::JsonLocator(const std::string& text) : text_(text) {
  struct Container {
    bool isObject;
    size_t count;  // members or elements seen so far
    std::string pointer;
  };
  std::vector<Container> stack;
  size_t i = 0;
  auto skipSpace = [&] {
    while (i < text.size() && IsSpace(text[i])) ++i;
  };
  // Records the value starting at i and either skips it (scalars) or opens it (containers); false when the
  // container would nest too deep.
  auto startValue = [&](const std::string& pointer) -> bool {
    skipSpace();
    valueOffsets_.emplace(pointer, i);
    if (i >= text.size()) return true;
    const char c = text[i];
    if (c == '{' || c == '[') {
      if (stack.size() >= kMaxDepth) {
        tooDeepOffset_ = i;
        return false;
      }
      stack.push_back({c == '{', 0, pointer});
      ++i;
    } else if (c == '"') {
      i = ReadString(text, i, nullptr);
    } else {
      while (i < text.size() && !IsSpace(text[i]) && text[i] != ',' && text[i] != ']' && text[i] != '}') ++i;
    }
    return true;
  };

  if (!startValue("")) return;
  while (!stack.empty() && i < text.size()) {
    skipSpace();
    if (i >= text.size()) break;
    const char c = text[i];
    if (c == '}' || c == ']') {
      stack.pop_back();
      ++i;
      continue;
    }
    if (c == ',') {
      ++i;
      continue;
    }
    Container& top = stack.back();
    const size_t index = top.count++;
    if (top.isObject) {
      const size_t keyOffset = i;
      std::string key;
      i = ReadString(text, i, &key);
      const std::string child = PointerChild(top.pointer, key);
      if (!keyOffsets_.emplace(child, keyOffset).second && duplicateKey_.empty()) {
        duplicateKey_ = child;
        keyOffsets_[child] = keyOffset;  // point at the second occurrence
        valueOffsets_.erase(child);
      }
      skipSpace();
      if (i < text.size() && text[i] == ':') ++i;
      if (!startValue(child)) return;  // may push: do not use top afterwards
    } else {
      if (!startValue(PointerChild(top.pointer, index))) return;
    }
  }
}

SourcePos JsonLocator::ValuePos(const std::string& pointer) const {
  std::string p = pointer;
  for (;;) {
    auto it = valueOffsets_.find(p);
    if (it != valueOffsets_.end()) return PosFromOffset(text_, it->second);
    if (p.empty()) return SourcePos{};
    p.erase(p.rfind('/'));
  }
}

SourcePos JsonLocator::KeyPos(const std::string& pointer) const {
  auto it = keyOffsets_.find(pointer);
  if (it != keyOffsets_.end()) return PosFromOffset(text_, it->second);
  return ValuePos(pointer);
}

}  // namespace restir
