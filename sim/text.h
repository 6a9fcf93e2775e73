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

// Newlines and carriage returns replaced by spaces: messages stay on one line (DESIGN §10).
std::string OneLine(std::string s);

}  // namespace restir
