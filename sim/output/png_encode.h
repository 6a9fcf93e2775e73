// PNGs for the scrubber (sim/output/scrub_frames.h), written with libpng for what OpenImageIO's writer does not
// make: one byte a pixel, as a palette of 256 colours (a heat map) or as grey (a mask), which a browser shows as the
// same pixels as their RGB expansion for a third of the disk; and RGB deflated at zlib's fastest level.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace restir {

// `indices` (w x h, rows top to bottom) into `palette` (RGB triples), as an indexed-colour PNG, in memory.
std::string EncodeIndexedPng(const std::vector<unsigned char>& indices, int w, int h,
                             const std::array<unsigned char, 256 * 3>& palette);
// `rgb` (w x h, 3 bytes a pixel) as an sRGB-tagged RGB PNG, in memory, deflated at zlib's fastest level without row
// filters (on noisy tone-mapped renders they cost more than they save): about half of OpenImageIO's stored PNG.
std::string EncodeRgbPng(const std::vector<unsigned char>& rgb, int w, int h);
// `grey` (w x h, one byte a pixel) as a greyscale PNG, in memory.
std::string EncodeGreyPng(const std::vector<unsigned char>& grey, int w, int h);

// True when `bytes` are a whole PNG: the signature, then chunks whose lengths lead exactly to IEND at the end (a
// file cut anywhere fails). Checked without decoding, so a reader can refuse a damaged file before libpng prints
// its own complaint.
bool PngIsWhole(const std::string& bytes);

}  // namespace restir
