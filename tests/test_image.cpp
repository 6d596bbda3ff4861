// Image I/O: round trips through every format and error reporting on bad files.
#include <catch2/catch.hpp>
#include <limits>
#include <sys/stat.h>
#include <fstream>
#include <iterator>
#include "process.h"

#include <OpenEXR/ImfCRgbaFile.h>
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>
#include <unistd.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/image.h"

using namespace lt;
namespace fs = std::filesystem;
using Catch::Matchers::Contains;

namespace {

struct TempDir : lt::test::TempDir {
    TempDir() : lt::test::TempDir("lt_test_image") {}
};

// 5x3 (non-square, so a transposition or a vertical flip is detected), every value different,
// including negatives, tiny and large values.
Image testImage() {
    Image img(5, 3);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            img.at(x, y) = Color(x + 10.f * y + 0.25f, -0.5f * x + y, 1e-3f * (x + 1) * (y + 1));
    img.at(4, 2) = Color(1e6f, 3.5e-7f, -123.456f);
    return img;
}

// Only positive values with a moderate range (for RGBE and half).
Image positiveImage() {
    Image img(5, 3);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            img.at(x, y) = Color(0.1f + x + 7.f * y, 0.5f * (x + 1) / (y + 1), 0.03f * (x * x + y + 1));
    return img;
}

void requireEqual(const Image& a, const Image& b) {
    REQUIRE(a.width == b.width);
    REQUIRE(a.height == b.height);
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < 3; ++c) {
                INFO("pixel (" << x << ", " << y << ") channel " << c);
                REQUIRE(a.at(x, y)[c] == b.at(x, y)[c]);
            }
}

std::vector<char> readBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void writeBytes(const std::string& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), std::streamsize(bytes.size()));
}

void appendFloat(std::string& s, float f, bool bigEndian) {
    uint32_t bits;
    std::memcpy(&bits, &f, 4);
    unsigned char b[4];
    for (int i = 0; i < 4; ++i) b[i] = (unsigned char)(bits >> (8 * i));  // little-endian order
    if (bigEndian) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
    s.append(reinterpret_cast<const char*>(b), 4);
}

}  // namespace

TEST_CASE("EXR FLOAT round trip is bit exact", "[image][exr]") {
    TempDir tmp;
    Image img = testImage();
    std::string path = tmp.file("a.exr");
    writeExr(img, path);
    requireEqual(readImage(path), img);
    // Via writeImage, with an upper-case extension.
    std::string path2 = tmp.file("b.EXR");
    writeImage(img, path2);
    requireEqual(readImage(path2), img);
}

TEST_CASE("EXR HALF round trip within half precision", "[image][exr]") {
    TempDir tmp;
    Image img = positiveImage();
    img.at(0, 0) = Color(1.0001f, -2.f, 0.f);  // 1.0001 is not representable in half: rounds to 1
    std::string path = tmp.file("h.exr");
    writeExr(img, path, ExrPixelType::Half);
    Image back = readImage(path);
    REQUIRE(back.width == img.width);
    REQUIRE(back.height == img.height);
    // half has an 11-bit significand: relative rounding error <= 2^-11 = 4.9e-4.
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            for (int c = 0; c < 3; ++c)
                REQUIRE(std::abs(back.at(x, y)[c] - img.at(x, y)[c]) <= std::abs(img.at(x, y)[c]) * 4.9e-4f);
    // Proves the file really holds HALF data (a FLOAT file would return 1.0001 exactly).
    REQUIRE(back.at(0, 0).x == 1.0f);
}

TEST_CASE("Y-only greyscale EXR is read as grey RGB", "[image][exr]") {
    TempDir tmp;
    std::string path = tmp.file("grey.exr");
    const int w = 3, h = 2;
    const float vals[w * h] = {0.5f, 1.f, 2.f, 0.25f, 4.f, 0.f};
    std::vector<ImfRgba> px(w * h);
    for (int i = 0; i < w * h; ++i) {
        ImfFloatToHalf(vals[i], &px[i].r);
        px[i].g = px[i].b = px[i].r;
        ImfFloatToHalf(1.f, &px[i].a);
    }
    ImfHeader* hdr = ImfNewHeader();
    ImfHeaderSetDisplayWindow(hdr, 0, 0, w - 1, h - 1);
    ImfHeaderSetDataWindow(hdr, 0, 0, w - 1, h - 1);
    ImfOutputFile* out = ImfOpenOutputFile(path.c_str(), hdr, IMF_WRITE_Y);  // only a "Y" channel
    REQUIRE(out != nullptr);
    REQUIRE(ImfOutputSetFrameBuffer(out, px.data(), 1, w));
    REQUIRE(ImfOutputWritePixels(out, h));
    REQUIRE(ImfCloseOutputFile(out));
    ImfDeleteHeader(hdr);

    Image img = readImage(path);
    REQUIRE(img.width == w);
    REQUIRE(img.height == h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            // Y = 0.2126 R + 0.7152 G + 0.0722 B of a grey pixel is the grey value (up to half rounding).
            float v = vals[y * w + x];
            Color c = img.at(x, y);
            REQUIRE(c.x == Approx(v).margin(1e-6).epsilon(1e-3));
            REQUIRE(c.y == c.x);
            REQUIRE(c.z == c.x);
        }
}

TEST_CASE("PFM round trip (little endian, rows bottom-to-top)", "[image][pfm]") {
    TempDir tmp;
    Image img = testImage();
    std::string path = tmp.file("a.pfm");
    writePfm(img, path);
    requireEqual(readImage(path), img);

    // Layout check: header, then the bottom row first.
    std::vector<char> bytes = readBytes(path);
    const std::string header = "PF\n5 3\n-1.0\n";
    REQUIRE(bytes.size() == header.size() + 5 * 3 * 3 * 4);
    REQUIRE(std::string(bytes.data(), header.size()) == header);
    if (std::endian::native == std::endian::little) {
        float first;
        std::memcpy(&first, bytes.data() + header.size(), 4);
        REQUIRE(first == img.at(0, 2).x);  // pixel (0, bottom row)
    }
}

TEST_CASE("PFM written by hand in both byte orders", "[image][pfm]") {
    TempDir tmp;
    Image img = testImage();
    for (bool big : {true, false}) {
        INFO((big ? "big endian" : "little endian"));
        // Scale 2.5 / -0.75: only the sign matters (byte order); the magnitude is ignored.
        std::string s = std::string("PF\n") + "5 3\n" + (big ? "2.5" : "-0.75") + "\n";
        for (int y = img.height - 1; y >= 0; --y)
            for (int x = 0; x < img.width; ++x)
                for (int c = 0; c < 3; ++c) appendFloat(s, img.at(x, y)[c], big);
        std::string path = tmp.file(big ? "big.pfm" : "little.pfm");
        writeBytes(path, s);
        requireEqual(readImage(path), img);
    }
}

TEST_CASE("Greyscale Pf is replicated to RGB", "[image][pfm]") {
    TempDir tmp;
    // 2x2, big endian; rows bottom-to-top: file order is (0,1),(1,1),(0,0),(1,0).
    std::string s = "Pf\n2 2\n1\n";
    for (float v : {3.f, 4.f, 1.f, 2.f}) appendFloat(s, v, true);
    std::string path = tmp.file("g.pfm");
    writeBytes(path, s);
    Image img = readImage(path);
    REQUIRE(img.width == 2);
    REQUIRE(img.height == 2);
    REQUIRE(img.at(0, 0) == Color(1.f));
    REQUIRE(img.at(1, 0) == Color(2.f));
    REQUIRE(img.at(0, 1) == Color(3.f));
    REQUIRE(img.at(1, 1) == Color(4.f));
}

TEST_CASE("Radiance HDR written by stb reads back within RGBE precision", "[image][hdr]") {
    TempDir tmp;
    Image img = positiveImage();
    std::string path = tmp.file("a.hdr");
    REQUIRE(stbi_write_hdr(path.c_str(), img.width, img.height, 3, &img.pixels[0].x) != 0);
    Image back = readImage(path);
    REQUIRE(back.width == img.width);
    REQUIRE(back.height == img.height);
    // RGBE: one shared exponent, 8-bit mantissas, with the largest channel's mantissa in
    // [128, 256). stb truncates when encoding, so each channel loses less than one unit of
    // maxComp / 128 and never increases.
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            Color o = img.at(x, y), r = back.at(x, y);
            float tol = maxComp(o) / 128.f;
            for (int c = 0; c < 3; ++c) {
                INFO("pixel (" << x << ", " << y << ") channel " << c << ": " << o[c] << " -> " << r[c]);
                REQUIRE(std::abs(r[c] - o[c]) <= tol);
                REQUIRE(r[c] <= o[c] * (1.f + 1e-6f));
            }
        }
    // Orientation: the brightest pixel is at the bottom-right corner.
    REQUIRE(back.at(4, 2).x > back.at(4, 0).x);

    // writeImage(.hdr) produces the same thing.
    std::string path2 = tmp.file("b.hdr");
    writeImage(img, path2);
    requireEqual(readImage(path2), back);
}

TEST_CASE("PNG is written with exposure, sRGB curve and clamping", "[image][png]") {
    TempDir tmp;
    Image img(4, 1);
    img.at(0, 0) = Color(0.5f);        // sRGB(0.5) = 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354 -> 188
    img.at(1, 0) = Color(2.f, 1.f, 0.f);  // clamps to 255, 255, 0
    img.at(2, 0) = Color(-1.f);         // clamps to 0
    img.at(3, 0) = Color(0.002f);       // linear segment: 12.92 * 0.002 = 0.02584 -> 7
    std::string path = tmp.file("a.png");
    writePng(img, path);
    REQUIRE(fs::file_size(path) > 8);
    std::vector<char> bytes = readBytes(path);
    REQUIRE(std::memcmp(bytes.data(), "\x89PNG\r\n\x1a\n", 8) == 0);

    int w, h, n;
    unsigned char* px = stbi_load(path.c_str(), &w, &h, &n, 3);
    REQUIRE(px != nullptr);
    REQUIRE(w == 4);
    REQUIRE(h == 1);
    std::vector<int> got(px, px + 12);
    stbi_image_free(px);
    REQUIRE(got == std::vector<int>{188, 188, 188, 255, 255, 0, 0, 0, 0, 7, 7, 7});

    // Exposure +1 doubles: 0.25 -> 0.5 -> 188.
    Image quarter(1, 1, Color(0.25f));
    std::string path2 = tmp.file("b.png");
    writePng(quarter, path2, 1.f);
    px = stbi_load(path2.c_str(), &w, &h, &n, 3);
    REQUIRE(px != nullptr);
    int v = px[0];
    stbi_image_free(px);
    REQUIRE(v == 188);

    // writeImage dispatches .png.
    std::string path3 = tmp.file("c.png");
    writeImage(img, path3);
    REQUIRE(fs::file_size(path3) > 8);
}

TEST_CASE("No writer writes a NaN or infinite value: ImageError naming the file and the pixel, no file", "[image][errors]") {
    TempDir tmp;
    for (const float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity()}) {
        Image img(3, 2, Color(0.5f));
        img.at(2, 1) = Color(0.5f, bad, 0.5f);
        for (const char* ext : {".exr", ".pfm", ".png", ".hdr"}) {
            const std::string path = tmp.file(std::string("bad") + ext);
            INFO(path << " value " << bad);
            try {
                writeImage(img, path);
                FAIL("no ImageError");
            } catch (const ImageError& e) {
                const std::string what = e.what();
                CHECK(what.find(path) != std::string::npos);
                CHECK(what.find("pixel (2, 1)") != std::string::npos);
            }
            CHECK_FALSE(fs::exists(path));
        }
    }
}

TEST_CASE("Writers replace a file whole (a temporary file renamed over it), and a failed write keeps the old one", "[image][errors]") {
    // The file is replaced by a rename, not rewritten in place: its inode changes, so a reader that
    // had it open keeps reading the old file whole, and no reader sees a half-written one. No
    // temporary file is left, after a success or a failure; a failed write (a non-finite value,
    // or OpenEXR unable to write) leaves the previous file as it was.
    TempDir tmp;
    auto inode = [](const std::string& p) {
        struct stat st {};
        REQUIRE(::stat(p.c_str(), &st) == 0);
        return st.st_ino;
    };
    auto leftovers = [&] {
        int n = 0;
        for (const auto& e : fs::directory_iterator(tmp.dir)) n += e.path().string().find(".tmp") != std::string::npos;
        return n;
    };
    for (const char* ext : {".exr", ".pfm", ".png", ".hdr"}) {
        const std::string path = tmp.file(std::string("img") + ext);
        INFO(path);
        writeImage(Image(2, 2, Color(0.25f)), path);
        const auto first = inode(path);
        const auto before = readBytes(path);
        // Hold the first file open, as a viewer would, while it is replaced.
        std::ifstream held(path, std::ios::binary);
        writeImage(Image(2, 2, Color(0.75f)), path);
        CHECK(inode(path) != first);
        CHECK(readBytes(path) != before);
        std::vector<char> old((std::istreambuf_iterator<char>(held)), std::istreambuf_iterator<char>());
        CHECK(old == before);  // the reader that had it open still reads the old file whole
        const auto second = readBytes(path);
        Image bad(2, 2, Color(0.5f));
        bad.at(0, 0).x = std::numeric_limits<float>::quiet_NaN();
        CHECK_THROWS_AS(writeImage(bad, path), ImageError);
        CHECK(readBytes(path) == second);
        CHECK(leftovers() == 0);
    }
    // OpenEXR cannot write a file whose folder is a file: the error names the file, nothing is left.
    std::ofstream(tmp.file("plain")) << "x";
    CHECK_THROWS_AS(writeExr(Image(1, 1), tmp.file("plain") + "/a.exr"), ImageError);
    CHECK(leftovers() == 0);
}

TEST_CASE("Missing files and unknown extensions throw ImageError naming the file", "[image][errors]") {
    TempDir tmp;
    for (const char* name : {"missing.exr", "missing.pfm", "missing.hdr"}) {
        std::string path = tmp.file(name);
        REQUIRE_THROWS_AS(readImage(path), ImageError);
        REQUIRE_THROWS_WITH(readImage(path), Contains(path) && Contains("not found"));
    }
    std::string txt = tmp.file("a.txt");
    writeBytes(txt, "hello");
    REQUIRE_THROWS_AS(readImage(txt), ImageError);
    REQUIRE_THROWS_WITH(readImage(txt), Contains(txt) && Contains("extension"));
    REQUIRE_THROWS_WITH(readImage(tmp.file("noext")), Contains("noext") && Contains("extension"));
    // A directory is not an image.
    std::string dir = tmp.file("dir.exr");
    fs::create_directories(dir);
    REQUIRE_THROWS_WITH(readImage(dir), Contains(dir));

    Image img(2, 2, Color(1.f));
    std::string bad = tmp.file("a.tiff");
    REQUIRE_THROWS_WITH(writeImage(img, bad), Contains(bad) && Contains("extension"));
    std::string noDir = tmp.file("no/such/dir/x.exr");
    REQUIRE_THROWS_WITH(writeImage(img, noDir), Contains(noDir));
    std::string noDirPfm = tmp.file("no/such/dir/x.pfm");
    REQUIRE_THROWS_WITH(writeImage(img, noDirPfm), Contains(noDirPfm));
    std::string noDirPng = tmp.file("no/such/dir/x.png");
    REQUIRE_THROWS_WITH(writeImage(img, noDirPng), Contains(noDirPng));
    REQUIRE_THROWS_AS(writeImage(Image(), tmp.file("empty.exr")), ImageError);
}

TEST_CASE("Corrupt files throw ImageError naming the file instead of crashing", "[image][errors]") {
    TempDir tmp;
    auto expectError = [&](const std::string& name, const std::string& bytes, const char* what) {
        std::string path = tmp.file(name);
        writeBytes(path, bytes);
        INFO(name);
        REQUIRE_THROWS_AS(readImage(path), ImageError);
        REQUIRE_THROWS_WITH(readImage(path), Contains(path) && Contains(what));
    };
    const char* any = "";
    expectError("garbage.exr", std::string(200, '\x17'), any);
    expectError("empty.exr", "", any);
    expectError("empty.pfm", "", "header");
    expectError("magic.pfm", "P6\n2 2\n-1\n" + std::string(48, '\0'), "header");
    expectError("nowidth.pfm", "PF\n", "header");
    expectError("negwidth.pfm", "PF\n-2 2\n-1\n" + std::string(48, '\0'), "header");
    expectError("zeroheight.pfm", "PF\n2 0\n-1\n", "size");
    expectError("huge.pfm", "PF\n999999999 999999999\n-1\n", "too large");
    expectError("badscale.pfm", "PF\n2 2\nabc\n" + std::string(48, '\0'), "scale");
    expectError("zeroscale.pfm", "PF\n2 2\n0\n" + std::string(48, '\0'), "scale");
    expectError("truncated.pfm", "PF\n2 2\n-1\n" + std::string(47, '\0'), "size mismatch");
    expectError("garbage.hdr", std::string(100, 'x'), "Radiance");
    expectError("truncated.hdr", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100 +X 100\n\x02\x02", any);

    // A valid EXR cut short.
    std::string full = tmp.file("full.exr");
    Image big(64, 64, Color(0.3f, 0.6f, 0.9f));
    for (int i = 0; i < 64 * 64; ++i) big.pixels[i] *= float(i % 17);  // not trivially compressible
    writeExr(big, full);
    std::vector<char> bytes = readBytes(full);
    REQUIRE(bytes.size() > 400);
    for (size_t cut : {size_t(20), size_t(300), bytes.size() / 2, bytes.size() - 10})
        expectError("cut" + std::to_string(cut) + ".exr", std::string(bytes.data(), cut), any);
}
