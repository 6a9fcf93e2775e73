// Decoding an image's bytes without judging its values, for readers that refuse what DecodeTexture
// (sim/assets/texture.h) repairs: a texture's negative or non-finite texels read as black, an environment map's are
// errors naming the texel (docs/sequence-format.md "Sky"). Kept out of sim/assets/texture.h, which
// sim/scene/sequence.h and so most of the program include, because only those two readers need it.
#pragma once

#include <string>


namespace restir {

struct Texture;  // sim/assets/texture.h

// DecodeTexture's decoding (sRGB for integer images, linear for float ones; grey replicated, alpha dropped; the
// same size limits, the same child process) with the texels left as the file has them, possibly negative or
// non-finite. False with `problem` (one line, without the name) when the bytes are not an image, the image is too
// large, or the decoder crashed or hung on it.
bool TryDecodeLinearImage(const std::string& bytes, const std::string& name, Texture& image, std::string& problem);

}  // namespace restir
