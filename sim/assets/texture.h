// Base-colour and emission textures of imported assets (docs/sequence-format.md "Assets"): linear RGB texels,
// sampled bilinearly at a surface point with the sampler's wrap modes, or averaged over a triangle for an emitter.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/math.h"

namespace restir {

// How texel indices outside the image are brought back into it, per axis: glTF's sampler wrapS / wrapT (10497
// REPEAT, 33071 CLAMP_TO_EDGE, 33648 MIRRORED_REPEAT), with OpenGL's definitions (OpenGL 4.6 core, section 8.14.2).
enum class TextureWrap : uint8_t {
  kRepeat,          // index mod size: the image tiles
  kClampToEdge,     // the nearest edge texel
  kMirroredRepeat,  // the image and its mirror image alternate, the mirror image first below 0
};

struct Texture {
  std::string name;          // where it came from (file path, or "<asset>#<index>" for an embedded image)
  int width = 0;             // texels per row
  int height = 0;            // rows; row 0 is the image's top
  std::vector<float> rgb;    // linear RGB, row-major, 3 floats per texel, all finite and >= 0
  TextureWrap wrapU = TextureWrap::kRepeat;  // across columns (glTF wrapS)
  TextureWrap wrapV = TextureWrap::kRepeat;  // across rows (glTF wrapT)
  // The texel at (x, y), any integers, brought into the image by wrapU and wrapV.
  Vec3 Texel(int64_t x, int64_t y) const;
};

// Texture coordinates follow OpenGL's convention as Assimp delivers them: u to the right, v up, so v = 1 is the
// image's top row. The filter is bilinear between the four texel centres around (u W - 0.5, (1 - v) H - 0.5),
// each of the four texels wrapped by the texture's wrap modes; glTF's default sampler is REPEAT with linear
// magnification. No mip-mapping: the texture is read once per pixel at the primary hit, where the footprint
// matters only to anti-aliasing, which the simulator does not model (one primary ray per pixel centre).
Vec3 SampleBilinear(const Texture& texture, float u, float v);

// The mean of SampleBilinear over a triangle of texture space (the triangle's UVs), for an emissive triangle's
// radiance: the area average over an n x n subdivision into congruent sub-triangles, each sampled at its centroid,
// with n = the triangle's largest UV edge in texels rounded up, clamped to [1, 64]. Exact for a constant texture;
// otherwise within the texture's variation over one texel.
Vec3 MeanOverTriangle(const Texture& texture, const Vec2& uv0, const Vec2& uv1, const Vec2& uv2);

// sRGB's decoding (IEC 61966-2-1) of a value in [0, 1]: 8-bit colour textures (glTF baseColor and emissive,
// MTL map_Kd) are sRGB-encoded.
float SrgbToLinear(float encoded);

// Decodes an image (PNG, JPEG, EXR, HDR, ... whatever OpenImageIO reads) from memory into linear RGB: 8- and
// 16-bit integer images are taken as sRGB, float images as linear; grey is replicated, alpha dropped. Throws
// InputError "<name>: error: ..." (with the decoder's own diagnostic, which never reaches stderr) when the bytes
// are not an image or the image is beyond 16384 texels on a side or 2^26 in all (bounded before allocating). The
// decoder runs in a forked child (sim/util/isolation.h): bytes that crash or hang it are such an InputError too.
Texture DecodeTexture(const std::string& bytes, const std::string& name);

// An encoded image and its name, for DecodeTextures.
struct EncodedImage {
  const std::string* bytes;  // the file's bytes, alive for the call
  std::string name;          // as DecodeTexture's `name`
};

// DecodeTexture of each, in one child process for all (a fork costs more than a small texture's decoding): the
// same textures, and on failure the same InputError naming the first image that fails alone.
std::vector<Texture> DecodeTextures(const std::vector<EncodedImage>& images);

}  // namespace restir
