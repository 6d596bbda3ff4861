// Texture image files: float formats through lt::readImage, 8/16-bit formats through stb_image
// (whose implementation is compiled once, in core/image.cpp), sRGB-decoded as Mitsuba's Bitmap does
// for PNG, JPEG, BMP and TGA (src/core/bitmap.cpp: read_png & co. set srgb_gamma).
#include <stb/stb_image.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <new>
#include <vector>
#include "core/texture/texture_factory.h"

namespace lt {

namespace {

// As core/image.cpp: 2^28 texels = 3 GiB of RGB float.
constexpr int64_t kMaxPixels = int64_t(1) << 28;

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw ImageError(path + ": " + what); }

std::string lowerExtension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

double srgbToLinearExact(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

// Decoded value of every code 0..maxCode: sRGB-decoded, or code / maxCode when raw.
std::vector<float> decodeTable(int maxCode, bool raw) {
    std::vector<float> table(size_t(maxCode) + 1);
    for (int i = 0; i <= maxCode; ++i) {
        const double c = double(i) / maxCode;
        table[size_t(i)] = float(raw ? c : srgbToLinearExact(c));
    }
    return table;
}

// Interleaved 1..4-channel data to RGB: grey (1, 2 channels) replicated; alpha (2nd of 2, 4th of
// 4) ignored, as Mitsuba's bitmap texture stores Y or RGB only.
template <class T>
Image toRgb(const T* data, int w, int h, int channels, const std::vector<float>& table) {
    Image img(w, h);
    const size_t n = size_t(w) * size_t(h);
    for (size_t i = 0; i < n; ++i) {
        const T* p = data + i * size_t(channels);
        img.pixels[i] = channels >= 3 ? Color(table[p[0]], table[p[1]], table[p[2]]) : Color(table[p[0]]);
    }
    return img;
}

Image loadFloatImage(const std::string& path) {
    Image img = readImage(path);  // ImageError names the file
    if (img.width <= 0 || img.height <= 0) fail(path, "the image has zero size");
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            if (!isFinite(img.at(x, y)))
                fail(path, "pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                               ") is NaN or infinite (a texture must be finite)");
    return img;
}

Image loadStbImage(const std::string& path, bool raw) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) fail(path, "file not found");
    if (std::filesystem::is_directory(path, ec)) fail(path, "is a directory, not an image file");
    std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "rb"), std::fclose);
    if (!file) fail(path, std::string("cannot open: ") + std::strerror(errno));

    int w = 0, h = 0, channels = 0;
    if (!stbi_info_from_file(file.get(), &w, &h, &channels))
        fail(path, std::string("not a readable PNG, JPEG, BMP or TGA image (stb_image: ") + stbi_failure_reason() + ")");
    if (w <= 0 || h <= 0) fail(path, "the image has zero size");
    if (int64_t(w) * h > kMaxPixels) fail(path, "image too large (" + std::to_string(w) + "x" + std::to_string(h) + ")");

    // Only PNG (of these formats) has 16 bits per channel; stb reports it here.
    const bool sixteen = stbi_is_16_bit_from_file(file.get()) != 0;
    void* raw_data = sixteen ? static_cast<void*>(stbi_load_from_file_16(file.get(), &w, &h, &channels, 0))
                             : static_cast<void*>(stbi_load_from_file(file.get(), &w, &h, &channels, 0));
    std::unique_ptr<void, void (*)(void*)> data(raw_data, stbi_image_free);
    if (!data) fail(path, std::string("cannot decode the image (stb_image: ") + stbi_failure_reason() + ")");
    if (w <= 0 || h <= 0) fail(path, "the image has zero size");
    if (channels < 1 || channels > 4) fail(path, "unsupported channel count " + std::to_string(channels));

    if (sixteen)
        return toRgb(static_cast<const uint16_t*>(data.get()), w, h, channels, decodeTable(65535, raw));
    return toRgb(static_cast<const uint8_t*>(data.get()), w, h, channels, decodeTable(255, raw));
}

}  // namespace

float srgbToLinear(float encoded) { return float(srgbToLinearExact(double(encoded))); }

Image loadTextureImage(const std::string& path, bool raw) {
    const std::string ext = lowerExtension(path);
    try {
        // Float formats hold linear values: raw changes nothing.
        if (ext == ".exr" || ext == ".pfm" || ext == ".hdr") return loadFloatImage(path);
        if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".tga")
            return loadStbImage(path, raw);
    } catch (const std::bad_alloc&) {
        fail(path, "out of memory while reading");
    }
    fail(path, "unsupported texture image extension '" + ext +
                   "' (supported: .png, .jpg, .jpeg, .bmp, .tga, .exr, .pfm, .hdr)");
}

}  // namespace lt
