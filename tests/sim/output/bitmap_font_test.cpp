// The videos' captions: every character a preset name, a frame number or a caption uses has a glyph of its own,
// distinct glyphs draw distinct pixels, and text lands where it is put, clipped at the image's edges.
#include "sim/output/bitmap_font.h"

#include <gtest/gtest.h>

#include <set>

#include "sim/estimator/presets.h"

namespace restir {
namespace {

std::vector<unsigned char> Draw(const std::string& text, int scale, int& w, int& h) {
  w = TextWidth(text, scale) + 2;
  h = kGlyphHeight * scale + 2;
  std::vector<unsigned char> rgb(static_cast<size_t>(w) * h * 3, 0);
  const unsigned char ink[3] = {255, 255, 255};
  DrawText(rgb, w, h, 1, 1, text, scale, ink);
  return rgb;
}

TEST(BitmapFont, EveryCharacterOfThePresetNamesAndCaptionsHasAGlyph) {
  std::string text = "frame 0123456789/ reference error 0-1 all presets";
  for (const Preset& p : AllPresets()) text += p.name;
  for (char c : text) EXPECT_TRUE(HasGlyph(c)) << "'" << c << "'";
  EXPECT_FALSE(HasGlyph('#'));
  EXPECT_FALSE(HasGlyph('\n'));
}

TEST(BitmapFont, DistinctGlyphsDrawDistinctPixelsAndUppercaseDrawsLowercase) {
  const std::string glyphs = " 0123456789abcdefghijklmnopqrstuvwxyz-+_.:/()=%";
  std::set<std::vector<unsigned char>> seen;
  for (char c : glyphs) {
    int w = 0, h = 0;
    EXPECT_TRUE(seen.insert(Draw(std::string(1, c), 1, w, h)).second) << "'" << c << "' looks like another glyph";
  }
  int w1, h1, w2, h2;
  EXPECT_EQ(Draw("ReSTIR", 2, w1, h1), Draw("restir", 2, w2, h2));
}

TEST(BitmapFont, TextLandsWhereItIsPutAtItsScaleAndIsClippedAtTheEdges) {
  EXPECT_EQ(TextWidth("", 3), 0);
  EXPECT_EQ(TextWidth("1", 1), kGlyphWidth);
  EXPECT_EQ(TextWidth("12", 2), 2 * (kGlyphAdvance + kGlyphWidth));
  int w, h;
  const std::vector<unsigned char> rgb = Draw("l", 3, w, h);  // 'l' inks row 0 at columns 1-2
  auto lit = [&](int x, int y) { return rgb[(static_cast<size_t>(y) * w + x) * 3] == 255; };
  EXPECT_FALSE(lit(0, 0));
  EXPECT_FALSE(lit(1 + 2, 1));  // column 0 of the glyph is empty: pixels 1..3 of the image
  EXPECT_TRUE(lit(1 + 3, 1));
  EXPECT_TRUE(lit(1 + 3 + 5, 1 + 2));
  // Drawn partly outside the image: no write outside it (the vector's size would trip the sanitizers).
  std::vector<unsigned char> small(4 * 4 * 3, 0);
  const unsigned char ink[3] = {9, 9, 9};
  DrawText(small, 4, 4, -3, -3, "888", 2, ink);
  DrawText(small, 4, 4, 2, 2, "888", 2, ink);
  int inked = 0;
  for (size_t i = 0; i < small.size(); i += 3) inked += small[i] == 9;
  EXPECT_GT(inked, 0);
  EXPECT_LT(inked, 16);
}

}  // namespace
}  // namespace restir
