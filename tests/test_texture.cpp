// Textures (core/texture/): Mitsuba 3's bitmap look-ups (bilinear with the half-texel shift,
// nearest, the wrap modes on texel indices, to_uv, v = 0 at the image's top row), its checkerboard,
// and the texture image files (sRGB decoding of 8- and 16-bit data, float formats as stored,
// errors naming the file). Every expected value is computed by hand in the comments.
#include <catch2/catch.hpp>
#include <stb/stb_image_write.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/texture/texture_factory.h"
#include "process.h"

using namespace lt;
namespace fs = std::filesystem;
using Catch::Matchers::Contains;

namespace {

struct TempDir : lt::test::TempDir {
    TempDir() : lt::test::TempDir("lt_test_texture") {}
};

void requireColor(const Color& got, const Color& want, float eps = 1e-5f) {
    INFO("got (" << got.x << ", " << got.y << ", " << got.z << ") want (" << want.x << ", " << want.y << ", "
                 << want.z << ")");
    REQUIRE(got.x == Approx(want.x).margin(eps));
    REQUIRE(got.y == Approx(want.y).margin(eps));
    REQUIRE(got.z == Approx(want.z).margin(eps));
}

// 3x2 texels, (x, y) = Color(1 + x + 3y, 0.5 (x + 1), 2 + y), row y = 0 at the top:
//   row 0: (1, .5, 2) (2, 1, 2) (3, 1.5, 2)
//   row 1: (4, .5, 3) (5, 1, 3) (6, 1.5, 3)
Image image3x2() {
    Image img(3, 2);
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x) img.at(x, y) = Color(1.f + x + 3.f * y, 0.5f * (x + 1), 2.f + y);
    return img;
}

Color texel3x2(int x, int y) { return Color(1.f + x + 3.f * y, 0.5f * (x + 1), 2.f + y); }

const glm::mat3 kIdentity(1.f);

TexturePtr bitmap3x2(TextureFilter f, TextureWrap w, const glm::mat3& toUv = kIdentity) {
    return makeBitmap(image3x2(), f, w, toUv, "test3x2");
}

const std::array<TextureWrap, 3> kWraps{TextureWrap::Repeat, TextureWrap::Mirror, TextureWrap::Clamp};

std::string errorOf(const std::function<void()>& f) {
    try {
        f();
    } catch (const ImageError& e) {
        return e.what();
    }
    return "(no ImageError)";
}

// The message starts with "<path>: ".
void requireNamesFile(const std::string& msg, const std::string& path) {
    INFO(msg);
    REQUIRE(msg.rfind(path + ": ", 0) == 0);
}

// ---- A minimal PNG writer for 16-bit data (stb_image_write writes 8-bit only) ------------------
uint32_t crc32(const uint8_t* p, size_t n, uint32_t crc = 0) {
    crc = ~crc;
    for (size_t i = 0; i < n; ++i) {
        crc ^= p[i];
        for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

void putBe32(std::vector<uint8_t>& out, uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) out.push_back(uint8_t(v >> s));
}

void pngChunk(std::vector<uint8_t>& out, const char* type, const std::vector<uint8_t>& data) {
    putBe32(out, uint32_t(data.size()));
    std::vector<uint8_t> body(type, type + 4);
    body.insert(body.end(), data.begin(), data.end());
    out.insert(out.end(), body.begin(), body.end());
    putBe32(out, crc32(body.data(), body.size()));
}

// channels 1 (grey, colour type 0) or 3 (RGB, colour type 2); samples row-major, top row first.
void write16BitPng(const std::string& path, int w, int h, int channels, const std::vector<uint16_t>& samples) {
    std::vector<uint8_t> raw;  // filter byte 0 per row, then big-endian samples
    for (int y = 0; y < h; ++y) {
        raw.push_back(0);
        for (int i = 0; i < w * channels; ++i) {
            const uint16_t s = samples[size_t(y) * w * channels + i];
            raw.push_back(uint8_t(s >> 8));
            raw.push_back(uint8_t(s & 0xff));
        }
    }
    REQUIRE(raw.size() < 65536);  // one stored deflate block
    std::vector<uint8_t> z{0x78, 0x01, 0x01};
    const uint16_t len = uint16_t(raw.size());
    z.insert(z.end(), {uint8_t(len & 0xff), uint8_t(len >> 8), uint8_t(~len & 0xff), uint8_t((~len >> 8) & 0xff)});
    z.insert(z.end(), raw.begin(), raw.end());
    uint32_t a = 1, b = 0;  // Adler-32
    for (uint8_t c : raw) {
        a = (a + c) % 65521;
        b = (b + a) % 65521;
    }
    putBe32(z, (b << 16) | a);

    std::vector<uint8_t> png{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    std::vector<uint8_t> ihdr;
    putBe32(ihdr, uint32_t(w));
    putBe32(ihdr, uint32_t(h));
    ihdr.insert(ihdr.end(), {16, uint8_t(channels == 1 ? 0 : 2), 0, 0, 0});
    pngChunk(png, "IHDR", ihdr);
    pngChunk(png, "IDAT", z);
    pngChunk(png, "IEND", {});
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(png.data()), std::streamsize(png.size()));
}

// A PFM (little endian) with the given floats, bottom row first as the format stores them.
void writeRawPfm(const std::string& path, int w, int h, const std::vector<float>& values) {
    std::ofstream out(path, std::ios::binary);
    out << "PF\n" << w << ' ' << h << "\n-1.0\n";
    out.write(reinterpret_cast<const char*>(values.data()), std::streamsize(values.size() * sizeof(float)));
}

// Hand values of the sRGB curve: ((c + 0.055) / 1.055)^2.4 above 0.04045, c / 12.92 below.
constexpr float kSrgb128 = 0.2158605f;   // 128 / 255
constexpr float kSrgb64 = 0.05126946f;   // 64 / 255
constexpr float kSrgb200 = 0.5775804f;   // 200 / 255
constexpr float kSrgb10 = 10.f / 255.f / 12.92f;  // linear segment

}  // namespace

// ---- bitmap look-ups ------------------------------------------------------------------------------

TEST_CASE("Bitmap returns each texel at its centre for every filter and wrap", "[texture][bitmap]") {
    for (TextureFilter f : {TextureFilter::Bilinear, TextureFilter::Nearest})
        for (TextureWrap w : kWraps) {
            TexturePtr t = bitmap3x2(f, w);
            for (int y = 0; y < 2; ++y)
                for (int x = 0; x < 3; ++x) requireColor(t->eval(Vec2((x + 0.5f) / 3.f, (y + 0.5f) / 2.f)), texel3x2(x, y));
        }
}

TEST_CASE("Bitmap v = 0 is the image's top row", "[texture][bitmap]") {
    // Mitsuba: the tensor is the bitmap's rows in file order, indexed [floor(v * h)][floor(u * w)].
    for (TextureFilter f : {TextureFilter::Bilinear, TextureFilter::Nearest}) {
        TexturePtr t = bitmap3x2(f, TextureWrap::Clamp);
        requireColor(t->eval(Vec2(0.5f / 3.f, 0.25f)), Color(1.f, 0.5f, 2.f));  // top-left texel
        requireColor(t->eval(Vec2(0.5f / 3.f, 0.75f)), Color(4.f, 0.5f, 3.f));  // bottom-left texel
        requireColor(t->eval(Vec2(2.5f / 3.f, 0.25f)), Color(3.f, 1.5f, 2.f));  // top-right texel
    }
}

TEST_CASE("Bilinear bitmap interpolates between texel centres", "[texture][bitmap]") {
    for (TextureWrap w : kWraps) {
        TexturePtr t = bitmap3x2(TextureFilter::Bilinear, w);
        // u = 1/3: p.x = 1 - 0.5 = 0.5, halfway between texels 0 and 1 of row 0.
        requireColor(t->eval(Vec2(1.f / 3.f, 0.25f)), Color(1.5f, 0.75f, 2.f));
        // v = 0.5: p.y = 0.5, halfway between the rows at x = 0.
        requireColor(t->eval(Vec2(0.5f / 3.f, 0.5f)), Color(2.5f, 0.5f, 2.5f));
        // (0.3, 0.6): p = (0.4, 0.7): row 0 1 * 0.6 + 2 * 0.4 = 1.4, row 1 4.4; 1.4 * 0.3 + 4.4 * 0.7 = 3.5;
        // green 0.5 * 0.6 + 1 * 0.4 = 0.7; blue 2 * 0.3 + 3 * 0.7 = 2.7.
        requireColor(t->eval(Vec2(0.3f, 0.6f)), Color(3.5f, 0.7f, 2.7f));
    }
}

TEST_CASE("Bilinear bitmap borders follow the wrap mode", "[texture][bitmap]") {
    TexturePtr rep = bitmap3x2(TextureFilter::Bilinear, TextureWrap::Repeat);
    TexturePtr mir = bitmap3x2(TextureFilter::Bilinear, TextureWrap::Mirror);
    TexturePtr cla = bitmap3x2(TextureFilter::Bilinear, TextureWrap::Clamp);
    // u = 0 (v = 0.25, row 0 alone): p.x = -0.5, texels -1 and 0 half each. Repeat: -1 -> 2;
    // mirror and clamp: -1 -> 0.
    requireColor(rep->eval(Vec2(0.f, 0.25f)), Color(2.f, 1.f, 2.f));
    requireColor(mir->eval(Vec2(0.f, 0.25f)), Color(1.f, 0.5f, 2.f));
    requireColor(cla->eval(Vec2(0.f, 0.25f)), Color(1.f, 0.5f, 2.f));
    // u = 1: p.x = 2.5, texels 2 and 3. Repeat: 3 -> 0; mirror and clamp: 3 -> 2.
    requireColor(rep->eval(Vec2(1.f, 0.25f)), Color(2.f, 1.f, 2.f));
    requireColor(mir->eval(Vec2(1.f, 0.25f)), Color(3.f, 1.5f, 2.f));
    requireColor(cla->eval(Vec2(1.f, 0.25f)), Color(3.f, 1.5f, 2.f));
    // Corner (0, 0): p = (-0.5, -0.5). Repeat: texels (2|0) x (1|0), a quarter each:
    // (3 + 1 + 6 + 4) / 4 = 3.5, (1.5 + 0.5) / 2 = 1, (2 + 3) / 2 = 2.5. Mirror, clamp: texel (0, 0).
    requireColor(rep->eval(Vec2(0.f, 0.f)), Color(3.5f, 1.f, 2.5f));
    requireColor(mir->eval(Vec2(0.f, 0.f)), Color(1.f, 0.5f, 2.f));
    requireColor(cla->eval(Vec2(0.f, 0.f)), Color(1.f, 0.5f, 2.f));
    // Corner (1, 1): p = (2.5, 1.5). Repeat: the same four texels; mirror, clamp: texel (2, 1).
    requireColor(rep->eval(Vec2(1.f, 1.f)), Color(3.5f, 1.f, 2.5f));
    requireColor(mir->eval(Vec2(1.f, 1.f)), Color(6.f, 1.5f, 3.f));
    requireColor(cla->eval(Vec2(1.f, 1.f)), Color(6.f, 1.5f, 3.f));
}

TEST_CASE("Bilinear bitmap outside the unit square repeats or mirrors or clamps", "[texture][bitmap]") {
    TexturePtr rep = bitmap3x2(TextureFilter::Bilinear, TextureWrap::Repeat);
    TexturePtr mir = bitmap3x2(TextureFilter::Bilinear, TextureWrap::Mirror);
    TexturePtr cla = bitmap3x2(TextureFilter::Bilinear, TextureWrap::Clamp);
    // u = 0.25 in row 0: p.x = 0.25: texels 0 and 1 at 0.75 / 0.25: (1.25, 0.625, 2).
    // u = 0.75: p.x = 1.75: texels 1 and 2 at 0.25 / 0.75: (2.75, 1.375, 2).
    const Color at025(1.25f, 0.625f, 2.f), at075(2.75f, 1.375f, 2.f);
    // u = 1.25: repeat = u 0.25; mirror = u 0.75 (p.x = 3.25: texels 3 -> 2 and 4 -> 1); clamp: texel 2.
    requireColor(rep->eval(Vec2(1.25f, 0.25f)), at025);
    requireColor(mir->eval(Vec2(1.25f, 0.25f)), at075);
    requireColor(cla->eval(Vec2(1.25f, 0.25f)), Color(3.f, 1.5f, 2.f));
    // u = -0.25: repeat = u 0.75; mirror = u 0.25 (p.x = -1.25: texels -2 -> 1 and -1 -> 0); clamp: texel 0.
    requireColor(rep->eval(Vec2(-0.25f, 0.25f)), at075);
    requireColor(mir->eval(Vec2(-0.25f, 0.25f)), at025);
    requireColor(cla->eval(Vec2(-0.25f, 0.25f)), Color(1.f, 0.5f, 2.f));
    // u = 2.25: repeat = u 0.25; mirror: period 2, so also u 0.25 (p.x = 6.25: texels 6 -> 0, 7 -> 1).
    requireColor(rep->eval(Vec2(2.25f, 0.25f)), at025);
    requireColor(mir->eval(Vec2(2.25f, 0.25f)), at025);
    // v = 1.25 at x = 0: p.y = 2 exactly, row 2: repeat -> row 0; mirror, clamp -> row 1.
    requireColor(rep->eval(Vec2(0.5f / 3.f, 1.25f)), Color(1.f, 0.5f, 2.f));
    requireColor(mir->eval(Vec2(0.5f / 3.f, 1.25f)), Color(4.f, 0.5f, 3.f));
    requireColor(cla->eval(Vec2(0.5f / 3.f, 1.25f)), Color(4.f, 0.5f, 3.f));
}

TEST_CASE("Nearest bitmap takes the texel under uv and wraps its index", "[texture][bitmap]") {
    TexturePtr rep = bitmap3x2(TextureFilter::Nearest, TextureWrap::Repeat);
    TexturePtr mir = bitmap3x2(TextureFilter::Nearest, TextureWrap::Mirror);
    TexturePtr cla = bitmap3x2(TextureFilter::Nearest, TextureWrap::Clamp);
    const Color t0 = texel3x2(0, 0), t1 = texel3x2(1, 0), t2 = texel3x2(2, 0);
    // No half-texel shift: floor(u * 3) without interpolation.
    requireColor(rep->eval(Vec2(0.01f, 0.25f)), t0);
    requireColor(rep->eval(Vec2(0.34f, 0.25f)), t1);
    requireColor(rep->eval(Vec2(0.999f, 0.25f)), t2);
    // u = 1: index 3. Repeat -> 0, mirror -> 2, clamp -> 2.
    requireColor(rep->eval(Vec2(1.f, 0.25f)), t0);
    requireColor(mir->eval(Vec2(1.f, 0.25f)), t2);
    requireColor(cla->eval(Vec2(1.f, 0.25f)), t2);
    // u = -0.01: index -1. Repeat -> 2, mirror -> 0, clamp -> 0.
    requireColor(rep->eval(Vec2(-0.01f, 0.25f)), t2);
    requireColor(mir->eval(Vec2(-0.01f, 0.25f)), t0);
    requireColor(cla->eval(Vec2(-0.01f, 0.25f)), t0);
    // u = 1.7: index 5. Repeat -> 2, mirror -> 0 (5 = 2 * 3 - 1 - 0), clamp -> 2.
    requireColor(rep->eval(Vec2(1.7f, 0.25f)), t2);
    requireColor(mir->eval(Vec2(1.7f, 0.25f)), t0);
    requireColor(cla->eval(Vec2(1.7f, 0.25f)), t2);
    // u = 2.2: index 6, the start of the next mirror period. Repeat -> 0, mirror -> 0, clamp -> 2.
    requireColor(rep->eval(Vec2(2.2f, 0.25f)), t0);
    requireColor(mir->eval(Vec2(2.2f, 0.25f)), t0);
    requireColor(cla->eval(Vec2(2.2f, 0.25f)), t2);
    // v: 0.49 -> row 0, 0.5 -> row 1; v = -0.2: row -1: repeat -> 1, mirror -> 0, clamp -> 0.
    requireColor(rep->eval(Vec2(0.1f, 0.49f)), texel3x2(0, 0));
    requireColor(rep->eval(Vec2(0.1f, 0.5f)), texel3x2(0, 1));
    requireColor(rep->eval(Vec2(0.1f, -0.2f)), texel3x2(0, 1));
    requireColor(mir->eval(Vec2(0.1f, -0.2f)), texel3x2(0, 0));
    requireColor(cla->eval(Vec2(0.1f, -0.2f)), texel3x2(0, 0));
}

TEST_CASE("Bitmap applies to_uv as an affine transform of u v 1", "[texture][bitmap]") {
    // uv' = (2u + 0.25, v): glm columns (2, 0, 0), (0, 1, 0), (0.25, 0, 1).
    const glm::mat3 m(Vec3(2.f, 0.f, 0.f), Vec3(0.f, 1.f, 0.f), Vec3(0.25f, 0.f, 1.f));
    TexturePtr bil = bitmap3x2(TextureFilter::Bilinear, TextureWrap::Repeat, m);
    TexturePtr nea = bitmap3x2(TextureFilter::Nearest, TextureWrap::Repeat, m);
    // (0, 0.25) -> (0.25, 0.25): p.x = 0.25: (1.25, 0.625, 2).
    requireColor(bil->eval(Vec2(0.f, 0.25f)), Color(1.25f, 0.625f, 2.f));
    // (0.5, 0.25) -> (1.25, 0.25), repeated: the same.
    requireColor(bil->eval(Vec2(0.5f, 0.25f)), Color(1.25f, 0.625f, 2.f));
    // Nearest at (0.3, 0.25) -> u' = 0.85: index floor(2.55) = 2 (without to_uv: index 0).
    requireColor(nea->eval(Vec2(0.3f, 0.25f)), texel3x2(2, 0));
    // A vertical flip v' = 1 - v: columns (1, 0, 0), (0, -1, 0), (0, 1, 1). v = 0.25 reads row 1.
    const glm::mat3 flip(Vec3(1.f, 0.f, 0.f), Vec3(0.f, -1.f, 0.f), Vec3(0.f, 1.f, 1.f));
    requireColor(bitmap3x2(TextureFilter::Nearest, TextureWrap::Clamp, flip)->eval(Vec2(0.1f, 0.25f)), texel3x2(0, 1));
    // The last row is ignored (Mitsuba's affine transform: no projective division).
    glm::mat3 junk = m;
    junk[0][2] = 3.f;
    junk[1][2] = 7.f;
    junk[2][2] = 5.f;
    requireColor(bitmap3x2(TextureFilter::Bilinear, TextureWrap::Repeat, junk)->eval(Vec2(0.f, 0.25f)),
                 Color(1.25f, 0.625f, 2.f));
}

TEST_CASE("Bitmap max and mean are per channel over the texels", "[texture][bitmap]") {
    Image img(2, 2);
    img.at(0, 0) = Color(0.1f, 0.2f, 0.3f);
    img.at(1, 0) = Color(0.5f, 0.f, 1.f);
    img.at(0, 1) = Color(2.f, 0.1f, 0.f);
    img.at(1, 1) = Color(0.f, 0.f, 0.5f);
    TexturePtr t = makeBitmap(img, TextureFilter::Bilinear, TextureWrap::Repeat, kIdentity, "two");
    requireColor(t->maxValue(), Color(2.f, 0.2f, 1.f));
    requireColor(t->meanValue(), Color(2.6f / 4.f, 0.3f / 4.f, 1.8f / 4.f));
    REQUIRE(t->name() == "two");
    TexturePtr u = bitmap3x2(TextureFilter::Nearest, TextureWrap::Clamp);
    requireColor(u->maxValue(), Color(6.f, 1.5f, 3.f));
    requireColor(u->meanValue(), Color(3.5f, 1.f, 2.5f));
}

TEST_CASE("Bitmap of one texel is constant", "[texture][bitmap]") {
    // Mitsuba pads it to 2x2 by repetition: the same value everywhere.
    TexturePtr t = makeBitmap(Image(1, 1, Color(0.3f, 0.6f, 0.9f)), TextureFilter::Bilinear, TextureWrap::Repeat,
                              kIdentity, "one");
    for (Vec2 uv : {Vec2(0.f), Vec2(0.3f, 0.9f), Vec2(-2.7f, 5.1f)}) requireColor(t->eval(uv), Color(0.3f, 0.6f, 0.9f));
}

TEST_CASE("Bitmap refuses empty images and non-finite texels and survives non-finite uv", "[texture][bitmap]") {
    requireNamesFile(errorOf([] { makeBitmap(Image(), TextureFilter::Bilinear, TextureWrap::Repeat, kIdentity, "empty"); }),
                     "empty");
    Image img = image3x2();
    img.at(1, 1).y = std::numeric_limits<float>::quiet_NaN();
    const std::string msg =
        errorOf([&] { makeBitmap(img, TextureFilter::Bilinear, TextureWrap::Repeat, kIdentity, "nan.exr"); });
    requireNamesFile(msg, "nan.exr");
    REQUIRE_THAT(msg, Contains("(1, 1)"));
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    for (TextureFilter f : {TextureFilter::Bilinear, TextureFilter::Nearest})
        for (TextureWrap w : kWraps) {
            TexturePtr t = bitmap3x2(f, w);
            for (Vec2 uv : {Vec2(nan, 0.25f), Vec2(0.25f, inf), Vec2(-inf, nan), Vec2(3e20f, -3e20f)})
                REQUIRE(isFinite(t->eval(uv)));
        }
}

// ---- checkerboard -------------------------------------------------------------------------------

TEST_CASE("Checkerboard has color0 where both uv fractions are at most one half", "[texture][checkerboard]") {
    const Color c0(1.f, 0.f, 0.f), c1(0.f, 0.f, 1.f);
    TexturePtr t = makeCheckerboard(c0, c1, kIdentity);
    requireColor(t->eval(Vec2(0.25f, 0.25f)), c0);
    requireColor(t->eval(Vec2(0.75f, 0.25f)), c1);
    requireColor(t->eval(Vec2(0.25f, 0.75f)), c1);
    requireColor(t->eval(Vec2(0.75f, 0.75f)), c0);
    // The comparison is strict: a fraction of exactly 0.5 is in the lower half.
    requireColor(t->eval(Vec2(0.5f, 0.25f)), c0);
    requireColor(t->eval(Vec2(0.5f, 0.5f)), c0);
    requireColor(t->eval(Vec2(0.501f, 0.25f)), c1);
    // Period 1 in u and v, negative coordinates through floor.
    requireColor(t->eval(Vec2(1.25f, 0.25f)), c0);
    requireColor(t->eval(Vec2(1.75f, 2.25f)), c1);
    requireColor(t->eval(Vec2(3.75f, -1.25f)), c0);  // fractions (0.75, 0.75)
    requireColor(t->eval(Vec2(-0.25f, 0.25f)), c1);  // fractions (0.75, 0.25)
    requireColor(t->eval(Vec2(-0.25f, -0.25f)), c0);
    requireColor(t->eval(Vec2(-0.75f, 0.25f)), c0);  // fractions (0.25, 0.25)
    REQUIRE(isFinite(t->eval(Vec2(std::numeric_limits<float>::quiet_NaN(), 0.f))));
}

TEST_CASE("Checkerboard applies to_uv", "[texture][checkerboard]") {
    const Color c0(1.f, 0.f, 0.f), c1(0.f, 0.f, 1.f);
    // Scale 2: (0.3, 0.1) -> (0.6, 0.2): c1; (0.3, 0.3) -> (0.6, 0.6): c0.
    TexturePtr s = makeCheckerboard(c0, c1, glm::mat3(Vec3(2.f, 0.f, 0.f), Vec3(0.f, 2.f, 0.f), Vec3(0.f, 0.f, 1.f)));
    requireColor(s->eval(Vec2(0.3f, 0.1f)), c1);
    requireColor(s->eval(Vec2(0.3f, 0.3f)), c0);
    // Offset (0.5, 0): (0.25, 0.25) -> (0.75, 0.25): c1.
    TexturePtr o = makeCheckerboard(c0, c1, glm::mat3(Vec3(1.f, 0.f, 0.f), Vec3(0.f, 1.f, 0.f), Vec3(0.5f, 0.f, 1.f)));
    requireColor(o->eval(Vec2(0.25f, 0.25f)), c1);
    requireColor(o->eval(Vec2(0.25f, 0.75f)), c0);
}

TEST_CASE("Checkerboard max and mean values", "[texture][checkerboard]") {
    TexturePtr t = makeCheckerboard(Color(0.4f, 0.1f, 0.7f), Color(0.2f, 0.3f, 0.7f), kIdentity);
    requireColor(t->maxValue(), Color(0.4f, 0.3f, 0.7f));
    requireColor(t->meanValue(), Color(0.3f, 0.2f, 0.7f));
    REQUIRE(t->name() == "checkerboard");
    REQUIRE_THROWS_AS(makeCheckerboard(Color(std::nanf("")), Color(0.2f), kIdentity), std::invalid_argument);
}

// ---- texture image files ------------------------------------------------------------------------

TEST_CASE("sRGB decoding follows the exact piecewise curve", "[texture][image]") {
    REQUIRE(srgbToLinear(0.f) == 0.f);
    REQUIRE(srgbToLinear(1.f) == Approx(1.f).margin(1e-7));
    REQUIRE(srgbToLinear(128.f / 255.f) == Approx(kSrgb128).margin(1e-7));
    REQUIRE(srgbToLinear(10.f / 255.f) == Approx(kSrgb10).margin(1e-9));
    REQUIRE(srgbToLinear(0.04045f) == Approx(0.04045f / 12.92f).margin(1e-9));  // the segments meet
}

TEST_CASE("8-bit PNG is sRGB-decoded unless raw", "[texture][image]") {
    TempDir tmp;
    const std::string path = tmp.file("rgb.png");
    const uint8_t px[] = {0, 255, 128, 10, 64, 200};  // 2x1 RGB
    REQUIRE(stbi_write_png(path.c_str(), 2, 1, 3, px, 2 * 3) != 0);
    Image dec = loadTextureImage(path, false);
    REQUIRE(dec.width == 2);
    REQUIRE(dec.height == 1);
    requireColor(dec.at(0, 0), Color(0.f, 1.f, kSrgb128), 1e-6f);
    requireColor(dec.at(1, 0), Color(kSrgb10, kSrgb64, kSrgb200), 1e-6f);
    Image raw = loadTextureImage(path, true);
    requireColor(raw.at(0, 0), Color(0.f, 1.f, 128.f / 255.f), 1e-7f);
    requireColor(raw.at(1, 0), Color(10.f / 255.f, 64.f / 255.f, 200.f / 255.f), 1e-7f);
}

TEST_CASE("Grey PNGs replicate grey and alpha is ignored", "[texture][image]") {
    TempDir tmp;
    const uint8_t grey[] = {128, 10};
    const uint8_t greyAlpha[] = {128, 0, 10, 255};
    const uint8_t rgba[] = {10, 64, 200, 0, 255, 0, 128, 17};
    REQUIRE(stbi_write_png(tmp.file("y.png").c_str(), 2, 1, 1, grey, 2) != 0);
    REQUIRE(stbi_write_png(tmp.file("ya.png").c_str(), 2, 1, 2, greyAlpha, 4) != 0);
    REQUIRE(stbi_write_png(tmp.file("rgba.png").c_str(), 2, 1, 4, rgba, 8) != 0);
    for (const char* name : {"y.png", "ya.png"}) {
        Image img = loadTextureImage(tmp.file(name), false);
        requireColor(img.at(0, 0), Color(kSrgb128), 1e-6f);
        requireColor(img.at(1, 0), Color(kSrgb10), 1e-6f);
    }
    Image img = loadTextureImage(tmp.file("rgba.png"), false);
    requireColor(img.at(0, 0), Color(kSrgb10, kSrgb64, kSrgb200), 1e-6f);
    requireColor(img.at(1, 0), Color(1.f, 0.f, kSrgb128), 1e-6f);
}

TEST_CASE("16-bit PNG keeps 16-bit precision", "[texture][image]") {
    TempDir tmp;
    // 65535 = 255 * 257: 32896 = 128 * 257 and 2570 = 10 * 257 are the 8-bit codes 128 and 10.
    write16BitPng(tmp.file("rgb16.png"), 2, 1, 3, {0, 65535, 32896, 2570, 1, 65534});
    Image dec = loadTextureImage(tmp.file("rgb16.png"), false);
    requireColor(dec.at(0, 0), Color(0.f, 1.f, kSrgb128), 1e-6f);
    // 1 / 65535 on the linear segment: 1 / 65535 / 12.92 = 1.181039e-6, below any 8-bit step.
    REQUIRE(dec.at(1, 0).x == Approx(kSrgb10).margin(1e-7));
    REQUIRE(dec.at(1, 0).y == Approx(1.181039e-6).margin(1e-11));
    REQUIRE(dec.at(1, 0).z < 1.f);
    Image raw = loadTextureImage(tmp.file("rgb16.png"), true);
    requireColor(raw.at(0, 0), Color(0.f, 1.f, 32896.f / 65535.f), 1e-7f);
    REQUIRE(raw.at(1, 0).y == Approx(1.0 / 65535.0).margin(1e-11));
    write16BitPng(tmp.file("grey16.png"), 1, 2, 1, {32896, 2570});
    Image g = loadTextureImage(tmp.file("grey16.png"), false);
    REQUIRE(g.height == 2);
    requireColor(g.at(0, 0), Color(kSrgb128), 1e-6f);
    requireColor(g.at(0, 1), Color(kSrgb10), 1e-7f);
}

TEST_CASE("BMP TGA and JPEG load top row first", "[texture][image]") {
    TempDir tmp;
    // 8x8: the top half red (255, 0, 0), the bottom half (128, 64, 200); JPEG blocks are 8x8, so
    // the halves share a block and JPEG is checked only at the corners, with a tolerance.
    std::vector<uint8_t> px(8 * 8 * 3);
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) {
            uint8_t* p = &px[size_t(y * 8 + x) * 3];
            const uint8_t top[3] = {255, 0, 0}, bottom[3] = {128, 64, 200};
            std::memcpy(p, y < 4 ? top : bottom, 3);
        }
    REQUIRE(stbi_write_bmp(tmp.file("a.bmp").c_str(), 8, 8, 3, px.data()) != 0);
    REQUIRE(stbi_write_tga(tmp.file("a.TGA").c_str(), 8, 8, 3, px.data()) != 0);
    REQUIRE(stbi_write_jpg(tmp.file("a.jpeg").c_str(), 8, 8, 3, px.data(), 100) != 0);
    REQUIRE(stbi_write_jpg(tmp.file("a.jpg").c_str(), 8, 8, 3, px.data(), 100) != 0);
    for (const char* name : {"a.bmp", "a.TGA"}) {
        INFO(name);
        Image img = loadTextureImage(tmp.file(name), false);
        REQUIRE(img.width == 8);
        REQUIRE(img.height == 8);
        requireColor(img.at(3, 0), Color(1.f, 0.f, 0.f), 1e-6f);
        requireColor(img.at(3, 7), Color(kSrgb128, kSrgb64, kSrgb200), 1e-6f);
    }
    for (const char* name : {"a.jpeg", "a.jpg"}) {
        INFO(name);
        Image img = loadTextureImage(tmp.file(name), true);
        REQUIRE(img.width == 8);
        requireColor(img.at(0, 0), Color(1.f, 0.f, 0.f), 0.1f);
        requireColor(img.at(7, 7), Color(128.f / 255.f, 64.f / 255.f, 200.f / 255.f), 0.1f);
    }
}

TEST_CASE("A PNG's top row is the bitmap texture's v = 0", "[texture][image][bitmap]") {
    TempDir tmp;
    const uint8_t px[] = {255, 0, 0, 0, 0, 255};  // 1x2: red on top, blue below
    REQUIRE(stbi_write_png(tmp.file("rows.png").c_str(), 1, 2, 3, px, 3) != 0);
    TexturePtr t = makeBitmap(loadTextureImage(tmp.file("rows.png"), false), TextureFilter::Nearest,
                              TextureWrap::Repeat, kIdentity, "rows.png");
    requireColor(t->eval(Vec2(0.5f, 0.25f)), Color(1.f, 0.f, 0.f));
    requireColor(t->eval(Vec2(0.5f, 0.75f)), Color(0.f, 0.f, 1.f));
}

TEST_CASE("Float texture images load unchanged", "[texture][image]") {
    TempDir tmp;
    Image img(3, 2);
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x) img.at(x, y) = Color(x + 10.f * y + 0.25f, -0.5f * x + y, 1e-3f * (x + 1) * (y + 1));
    img.at(2, 1) = Color(1e6f, 3.5e-7f, -123.456f);
    writeExr(img, tmp.file("t.exr"));
    writePfm(img, tmp.file("t.pfm"));
    for (const char* name : {"t.exr", "t.pfm"})
        for (bool raw : {false, true}) {
            INFO(name << " raw " << raw);
            Image got = loadTextureImage(tmp.file(name), raw);
            REQUIRE(got.width == 3);
            REQUIRE(got.height == 2);
            for (int y = 0; y < 2; ++y)
                for (int x = 0; x < 3; ++x) REQUIRE(got.at(x, y) == img.at(x, y));
        }
    // Radiance HDR: what lt::readImage reads (RGBE precision), not sRGB-decoded.
    Image pos(2, 1);
    pos.at(0, 0) = Color(0.5f, 2.f, 0.25f);
    pos.at(1, 0) = Color(4.f, 1.f, 0.125f);
    writeHdr(pos, tmp.file("t.hdr"));
    Image hdr = loadTextureImage(tmp.file("t.hdr"), false);
    requireColor(hdr.at(0, 0), pos.at(0, 0));
    requireColor(hdr.at(1, 0), pos.at(1, 0));
}

TEST_CASE("Texture image errors name the file", "[texture][image]") {
    TempDir tmp;
    // Missing files, through both readers.
    for (const char* name : {"missing.png", "missing.exr", "missing.jpg"}) {
        const std::string path = tmp.file(name);
        requireNamesFile(errorOf([&] { loadTextureImage(path, false); }), path);
    }
    REQUIRE_THAT(errorOf([&] { loadTextureImage(tmp.file("missing.png"), false); }), Contains("file not found"));
    // A text file named .png, an empty one, and a truncated PNG.
    const std::string text = tmp.file("text.png");
    std::ofstream(text) << "this is not an image\n";
    std::string msg = errorOf([&] { loadTextureImage(text, false); });
    requireNamesFile(msg, text);
    REQUIRE_THAT(msg, Contains("not a readable"));
    const std::string empty = tmp.file("empty.png");
    std::ofstream(empty).close();
    requireNamesFile(errorOf([&] { loadTextureImage(empty, false); }), empty);
    const std::string whole = tmp.file("whole.png"), cut = tmp.file("cut.png");
    std::vector<uint8_t> px(16 * 16 * 3, 77);
    for (size_t i = 0; i < px.size(); ++i) px[i] = uint8_t(i * 37);
    REQUIRE(stbi_write_png(whole.c_str(), 16, 16, 3, px.data(), 16 * 3) != 0);
    {
        std::ifstream in(whole, std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    }
    requireNamesFile(errorOf([&] { loadTextureImage(cut, false); }), cut);
    // A directory.
    const std::string dir = tmp.file("dir.png");
    fs::create_directories(dir);
    requireNamesFile(errorOf([&] { loadTextureImage(dir, false); }), dir);
    // Unsupported extensions (stb could read a GIF; Mitsuba's bitmap does not).
    for (const char* name : {"image.gif", "image.txt", "noextension"}) {
        const std::string path = tmp.file(name);
        std::ofstream(path) << "x";
        msg = errorOf([&] { loadTextureImage(path, false); });
        requireNamesFile(msg, path);
        REQUIRE_THAT(msg, Contains("unsupported"));
    }
    // NaN and infinity in a PFM.
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    const std::string nanPfm = tmp.file("nan.pfm"), infPfm = tmp.file("inf.pfm");
    writeRawPfm(nanPfm, 2, 1, {0.f, 0.5f, 1.f, 0.25f, nan, 0.f});
    writeRawPfm(infPfm, 1, 2, {0.f, 0.5f, 1.f, inf, 0.f, 0.f});
    msg = errorOf([&] { loadTextureImage(nanPfm, false); });
    requireNamesFile(msg, nanPfm);
    REQUIRE_THAT(msg, Contains("NaN") && Contains("(1, 0)"));
    msg = errorOf([&] { loadTextureImage(infPfm, true); });
    requireNamesFile(msg, infPfm);
    REQUIRE_THAT(msg, Contains("infinite") && Contains("(0, 0)"));  // the top row is stored last
    // Zero size.
    const std::string zero = tmp.file("zero.pfm");
    writeRawPfm(zero, 0, 1, {});
    requireNamesFile(errorOf([&] { loadTextureImage(zero, false); }), zero);
}
