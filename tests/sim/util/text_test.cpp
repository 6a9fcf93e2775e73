// The message helpers: whatever bytes a file holds, what reaches the terminal is one line with no control byte.
#include "sim/util/text.h"

#include <gtest/gtest.h>

#include <string>

namespace restir {
namespace {

bool HasControlByte(const std::string& s) {
  for (char c : s)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) == 0x7f) return true;
  return false;
}

TEST(OneLine, EveryByteValueLeavesNoControlByteAndLineBreaksBecomeSpaces) {
  std::string all;
  for (int b = 0; b < 256; ++b) all += static_cast<char>(b);
  const std::string out = OneLine(all);
  EXPECT_FALSE(HasControlByte(out));
  EXPECT_EQ(OneLine("a\nb\r\nc\td"), "a b  c d");
  EXPECT_EQ(OneLine(std::string("x\0y\x1b[1m\x7fz", 9)), "x\\x00y\\x1b[1m\\x7fz");
  EXPECT_EQ(OneLine("caf\xc3\xa9.json"), "caf\xc3\xa9.json");  // UTF-8 unchanged
  EXPECT_EQ(OneLine(""), "");
}

TEST(Printable, EscapesAllButPrintableAsciiAndCutsLongText) {
  std::string all;
  for (int b = 0; b < 256; ++b) all += static_cast<char>(b);
  const std::string out = Printable(all, all.size());
  for (char c : out) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << int(c);
  // Every byte is recoverable: 95 printable bytes but the backslash shown as themselves, 162 as \xNN.
  EXPECT_EQ(out.size(), 94u + 162u * 4u);
  EXPECT_EQ(Printable("a\\b"), "a\\x5cb");  // a backslash in the text is not mistaken for an escape
  EXPECT_EQ(Printable("abc", 3), "abc");
  EXPECT_EQ(Printable("abcdef", 2), "ab... (4 more bytes)");
  EXPECT_EQ(Printable(std::string(1 << 20, 'q')).size(), 64u + std::string("... (1048512 more bytes)").size());
  EXPECT_EQ(Printable(""), "");
}

}  // namespace
}  // namespace restir
