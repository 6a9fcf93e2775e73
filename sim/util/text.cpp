#include "sim/util/text.h"

#include <algorithm>

namespace restir {

size_t EditDistance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

std::string Suggestion(const std::string& given, const std::vector<std::string>& candidates) {
  if (candidates.empty()) return "";
  const std::string* best = nullptr;
  size_t bestDistance = 0;
  for (const std::string& c : candidates) {
    const size_t d = EditDistance(given, c);
    if (!best || d < bestDistance) {
      best = &c;
      bestDistance = d;
    }
  }
  const size_t limit = std::max<size_t>(2, std::min(given.size(), best->size()) / 3);
  if (bestDistance <= limit) return " (did you mean '" + *best + "'?)";
  return " (expected one of: " + Joined(candidates, ", ") + ")";
}

std::string XmlEscape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      case '\'': o += "&#39;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string Joined(const std::vector<std::string>& items, const std::string& separator) {
  std::string s;
  for (const std::string& x : items) s += (s.empty() ? "" : separator) + x;
  return s;
}

namespace {

void AppendHexEscape(std::string& out, unsigned char b) {
  static const char kHex[] = "0123456789abcdef";
  out += "\\x";
  out += kHex[b >> 4];
  out += kHex[b & 15];
}

}  // namespace

std::string OneLine(std::string s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    const auto b = static_cast<unsigned char>(c);
    if (c == '\n' || c == '\r' || c == '\t') out += ' ';
    else if (b < 0x20 || b == 0x7f) AppendHexEscape(out, b);
    else out += c;
  }
  return out;
}

std::string Printable(std::string_view s, size_t maxBytes) {
  std::string out;
  const size_t shown = std::min(s.size(), maxBytes);
  for (size_t i = 0; i < shown; ++i) {
    const auto b = static_cast<unsigned char>(s[i]);
    if (b >= 0x20 && b < 0x7f && b != '\\') out += static_cast<char>(b);
    else AppendHexEscape(out, b);
  }
  if (shown < s.size()) out += "... (" + std::to_string(s.size() - shown) + " more bytes)";
  return out;
}

}  // namespace restir
