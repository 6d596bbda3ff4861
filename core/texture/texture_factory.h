// The textures: Mitsuba 3's `bitmap` and `checkerboard` plugins (src/textures/bitmap.cpp,
// src/textures/checkerboard.cpp; their documentation is the spec), and the image files a bitmap
// reads.
//
// Conventions shared by both (Mitsuba's):
//  - to_uv is an affine 3x3 transform of the point (u, v, 1): uv' = (toUv * Vec3(u, v, 1)).xy,
//    the translation in column 2 (glm is column-major); the last row is ignored, no division.
//  - v = 0 is the image's top row (row 0 of an lt::Image), v = 1 its bottom; u = 0 its left.
#pragma once
#include <string>
#include "core/image.h"
#include "core/texture/texture.h"

namespace lt {

enum class TextureFilter { Bilinear, Nearest };
enum class TextureWrap { Repeat, Mirror, Clamp };

// Mitsuba's checkerboard: with (s, t) = fract(to_uv(uv)), color0 where (s > 0.5) == (t > 0.5),
// color1 elsewhere: color0 on [0, 0.5]^2 and (0.5, 1)^2, a 2x2 pattern repeating with period 1.
// Throws std::invalid_argument for a non-finite colour.
TexturePtr makeCheckerboard(const Color& color0, const Color& color1, const glm::mat3& toUv);

// Mitsuba's bitmap over `linearRgb` (linear values, row 0 at the top; see loadTextureImage).
// Bilinear: p = uv' * (width, height) - 0.5, the four texels around floor(p) each wrapped, weights
// from fract(p). Nearest: the texel floor(uv' * (width, height)), wrapped. Wrap on a texel index i
// of a dimension of size n: Repeat i mod n; Mirror reflects with the edge texel repeated
// (..., 1, 0 | 0, 1, ..., n-1 | n-1, ...); Clamp to [0, n-1]. maxValue is the per-channel maximum
// over the texels (interpolation weights are non-negative), meanValue the per-channel mean.
// A non-finite component of uv' is taken as 0 (never a NaN out). Throws ImageError
// "<name>: ..." for an empty image or a non-finite texel.
TexturePtr makeBitmap(Image linearRgb, TextureFilter filter, TextureWrap wrap, const glm::mat3& toUv,
                      std::string name);

// One value everywhere, as given (Mitsuba's rawconstant). Throws std::invalid_argument if not finite.
TexturePtr makeConstantTexture(const Color& value);

// Reads a texture image by extension (case-insensitive):
//  .exr, .pfm, .hdr: lt::readImage, linear float data as stored;
//  .png, .jpg, .jpeg, .bmp, .tga: stb_image, 8 bits per channel, or 16 for a 16-bit PNG. These are
//    sRGB-encoded (Mitsuba's Bitmap marks every 8- and 16-bit PNG, JPEG, BMP and TGA so) and
//    decoded with srgbToLinear; raw = true keeps the stored value / 255 (/ 65535) as is.
// Grey and grey+alpha files replicate grey to RGB. Alpha is ignored, as Mitsuba's bitmap drops it:
// opacity belongs to the mask BSDF. Throws ImageError "<path>: <what is wrong>" for a missing or
// unreadable file, content that is not an image of the format, an unsupported extension, a zero
// size, or a NaN/infinite value in a float image.
Image loadTextureImage(const std::string& path, bool raw);

// The sRGB transfer curve's inverse (IEC 61966-2-1), exact: c / 12.92 for c <= 0.04045, else
// ((c + 0.055) / 1.055)^2.4. Mitsuba's dr::srgb_to_linear is a rational fit of this curve.
float srgbToLinear(float encoded);

}  // namespace lt
