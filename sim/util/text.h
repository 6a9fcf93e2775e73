// Text helpers shared by the readers, the report and the sweep: one place for each.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace restir {

// Levenshtein distance between two strings.
size_t EditDistance(std::string_view a, std::string_view b);

// " (did you mean 'x'?)" for a close candidate, else " (expected one of: a, b, c)", so a user who mistyped a key,
// a preset or a value always learns what is accepted. Empty when there are no candidates.
std::string Suggestion(const std::string& given, const std::vector<std::string>& candidates);

// `s` with &, <, >, " and ' escaped, for HTML and SVG text and attributes.
std::string XmlEscape(const std::string& s);

// `items` joined by `separator`.
std::string Joined(const std::vector<std::string>& items, const std::string& separator);

// Newlines, carriage returns and tabs replaced by spaces, any other control byte (NUL, ESC, DEL ...) written as
// \xNN: messages stay on one line and quote a file's bytes without handing them to the terminal (DESIGN §10). UTF-8
// passes unchanged, so a file's name reads as the user typed it.
std::string OneLine(std::string s);

// `s` quoted for a message when it came from a file: bytes outside printable ASCII as \xNN (a newline, a NUL or an
// escape sequence from a damaged file never reaches the terminal raw), and at most `maxBytes` of it shown, the rest
// counted ("... (N more bytes)"), so a megabyte of garbage is one short line.
std::string Printable(std::string_view s, size_t maxBytes = 64);

}  // namespace restir
