// What every fuzz target asks of a refusal (DESIGN §10): one message, on one line, with no control byte in it. The
// readers quote bytes from the file they refuse (a key, a cell, a token), so a newline, a NUL or an escape sequence
// there must arrive escaped; UTF-8 (a file's name) may pass.
#pragma once

#include <string>

inline bool IsOneCleanLine(const std::string& message) {
  if (message.empty()) return false;
  for (char c : message) {
    const auto b = static_cast<unsigned char>(c);
    if (b < 0x20 || b == 0x7f) return false;
  }
  return true;
}
