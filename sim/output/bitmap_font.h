// Text burned into 8-bit images (the videos' frame numbers and captions): a 5x7 pixel font of the project's own,
// drawn at an integer scale, so that the same string gives the same pixels on every machine (a system font
// through ffmpeg's drawtext would vary with the installed font's version).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace restir {

// The glyph cell: 5x7 pixels of ink and one column of spacing; lines are 9 pixels apart (all times the scale).
inline constexpr int kGlyphWidth = 5;
inline constexpr int kGlyphHeight = 7;
inline constexpr int kGlyphAdvance = 6;

// True when `c` has a glyph (digits, lowercase letters, space and - + _ . : / ( ) = %); uppercase letters are
// drawn as their lowercase glyph, anything else as a hollow box.
bool HasGlyph(char c);

// Pixels wide that `text` takes at `scale` (no trailing spacing).
int TextWidth(const std::string& text, int scale);

// Draws `text` into `rgb` (w x h, rows top to bottom, 3 bytes a pixel) with its top-left corner at (x, y), ink
// of colour `ink`; pixels outside the image are skipped.
void DrawText(std::vector<unsigned char>& rgb, int w, int h, int x, int y, const std::string& text, int scale,
              const unsigned char ink[3]);

}  // namespace restir
