// Exact (order-independent) film accumulation (core/exact_sum.h, core/film.h): the same samples
// added in any order, or split across films whose states are added (the MPI reduction), give the
// same bits.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include "core/exact_sum.h"
#include "core/film.h"

using namespace lt;

namespace {

using i128 = __int128;

// The exact fixed-point value of x (units of 2^-64), truncated toward zero: x 2^64 is a float
// scaled by a power of two, hence exact in a double, and the conversion to an integer truncates.
i128 reference(float x) { return i128(std::ldexp(double(x), 64)); }

ExactSum sumOf(const std::vector<float>& xs) {
    ExactSum s;
    for (float x : xs) s.add(x);
    return s;
}

// Log-uniform floats in [lo, hi) from a fixed seed.
std::vector<float> logUniform(size_t n, double lo, double hi, uint32_t seed) {
    std::mt19937 gen(seed);
    std::uniform_real_distribution<double> u(std::log(lo), std::log(hi));
    std::vector<float> xs(n);
    for (float& x : xs) x = float(std::exp(u(gen)));
    return xs;
}

// Samples for an 8 x 6 film: `passes` passes of one sample a pixel (colours log-uniform over
// 1e-6..1e4 a channel), and a few splats a pass at random raster positions.
struct Sample { int pass, x, y; Color c; };
struct Splat { int pass; Vec2 raster; Color c; };
constexpr int kW = 8, kH = 6;

std::vector<Sample> cameraSamples(int passes, uint32_t seed) {
    std::vector<Sample> out;
    std::vector<float> v = logUniform(size_t(passes) * kW * kH * 3, 1e-6, 1e4, seed);
    size_t k = 0;
    for (int p = 0; p < passes; ++p)
        for (int y = 0; y < kH; ++y)
            for (int x = 0; x < kW; ++x, k += 3) out.push_back({p, x, y, Color(v[k], v[k + 1], v[k + 2])});
    return out;
}

std::vector<Splat> splats(int passes, uint32_t seed) {
    std::vector<Splat> out;
    std::mt19937 gen(seed);
    std::uniform_real_distribution<float> rx(0.f, float(kW)), ry(0.f, float(kH));
    std::vector<float> v = logUniform(size_t(passes) * 20 * 3, 1e-8, 1e5, seed + 1);
    for (int p = 0; p < passes; ++p)
        for (int i = 0; i < 20; ++i) {
            const size_t k = (size_t(p) * 20 + i) * 3;
            const float x = rx(gen), y = ry(gen);
            out.push_back({p, Vec2(x, y), Color(v[k], v[k + 1], v[k + 2])});
        }
    return out;
}

// A film that received the given samples and splats in the given order (splats one buffer a
// pass, merged in the order given).
std::unique_ptr<Film> render(const std::vector<Sample>& samples, const std::vector<Splat>& sp) {
    auto film = std::make_unique<Film>(kW, kH, FilterType::Box);
    for (const Sample& s : samples) {
        film->addSample(s.x, s.y, s.c);
        film->addSampleCount(s.x, s.y, 1);
    }
    SplatBuffer buf;
    for (const Splat& s : sp) film->splat(buf, s.raster, s.c);
    film->mergeSplats(buf);
    return film;
}

template <class T, class Pred> std::vector<T> where(const std::vector<T>& v, Pred keep) {
    std::vector<T> out;
    for (const T& t : v)
        if (keep(t)) out.push_back(t);
    return out;
}

void requireSameImage(const Image& a, const Image& b) {
    REQUIRE(a.pixels.size() == b.pixels.size());
    for (size_t i = 0; i < a.pixels.size(); ++i) {
        CHECK(std::memcmp(&a.pixels[i], &b.pixels[i], sizeof(Color)) == 0);
    }
}

}  // namespace

TEST_CASE("ExactSum: hand values are exact and small ones truncate", "[exact]") {
    auto raw = [](std::initializer_list<float> xs) {
        ExactSum s;
        for (float x : xs) s.add(x);
        return s.v;
    };
    const i128 one = i128(1) << 64;
    CHECK(raw({1.f}) == one);
    CHECK(raw({0.5f}) == one / 2);
    CHECK(raw({0x1p-64f}) == 1);
    CHECK(raw({0x1p-70f}) == 0);                                 // below 2^-64: truncated to 0
    CHECK(raw({0x1.8p-64f}) == 1);                               // 1.5 units: truncated to 1
    CHECK(raw({std::numeric_limits<float>::denorm_min()}) == 0);  // subnormal
    CHECK(raw({0.f, -0.f}) == 0);
    CHECK(raw({0x1p61f}) == i128(1) << 125);
    CHECK(raw({0x1p61f, 0x1p61f, 0x1p61f}) == i128(3) << 125);  // 1.5 2^62 < 2^63
    CHECK(raw({3.0e-10f}) == reference(3.0e-10f));
    CHECK(ExactSum{raw({3.0e-10f})}.value() == double(3.0e-10f));  // exact: its last bit is 2^-55
    CHECK(raw({1.f, 0.5f, 0x1p-64f}) == one + one / 2 + 1);
    // value() rounds to nearest once: 1 + 2^-53 + 2^-64 is nearer 1 + 2^-52 than 1 (a double
    // sum, or a conversion that truncated, gives 1).
    ExactSum r;
    for (float x : {1.f, 0x1p-53f, 0x1p-64f}) r.add(x);
    CHECK(r.value() == 1.0 + 0x1p-52);
    CHECK(ExactSum{}.value() == 0.0);
    // The largest float the sum takes, and 2^-64, exactly.
    CHECK(ExactSum{raw({std::nextafter(0x1p62f, 0.f)})}.value() == double(std::nextafter(0x1p62f, 0.f)));
    CHECK(ExactSum{1}.value() == 0x1p-64);
}

TEST_CASE("ExactSum: every float is converted exactly or truncated toward zero", "[exact]") {
    // Random bit patterns over every exponent the sum takes (subnormals to just below 2^62),
    // against the double-precision reference.
    std::mt19937 gen(17);
    int checked = 0;
    for (int i = 0; i < 200000; ++i) {
        const uint32_t bits = gen() & 0x7fffffffu;
        float x;
        std::memcpy(&x, &bits, sizeof x);
        if (!ExactSum::representable(x)) continue;
        ExactSum s;
        s.add(x);
        if (s.v != reference(x)) FAIL("x = " << x << " (bits " << bits << ")");
        ++checked;
    }
    CHECK(checked > 140000);  // about 189 / 256 of the patterns are below 2^62
}

TEST_CASE("ExactSum: representable() takes finite non-negative values below 2^62", "[exact]") {
    CHECK_FALSE(ExactSum::representable(std::nanf("")));
    CHECK_FALSE(ExactSum::representable(-std::nanf("")));
    CHECK_FALSE(ExactSum::representable(std::numeric_limits<float>::infinity()));
    CHECK_FALSE(ExactSum::representable(-std::numeric_limits<float>::infinity()));
    CHECK_FALSE(ExactSum::representable(-1.f));
    CHECK_FALSE(ExactSum::representable(-std::numeric_limits<float>::denorm_min()));
    CHECK_FALSE(ExactSum::representable(0x1p62f));
    CHECK_FALSE(ExactSum::representable(1e30f));
    CHECK(ExactSum::representable(0.f));
    CHECK(ExactSum::representable(-0.f));
    CHECK(ExactSum::representable(std::numeric_limits<float>::denorm_min()));
    CHECK(ExactSum::representable(std::nextafter(0x1p62f, 0.f)));
    CHECK(ExactSum::representable(1.f));
    CHECK(ExactColorSum::representable(Color(0.f, 1.f, 2.f)));
    CHECK_FALSE(ExactColorSum::representable(Color(1.f, std::nanf(""), 2.f)));
    CHECK_FALSE(ExactColorSum::representable(Color(1.f, 2.f, -3.f)));
}

TEST_CASE("ExactSum: any order and any split of the terms gives the same bits", "[exact]") {
    const std::vector<float> xs = logUniform(10000, 1e-12, 1e6, 23);
    std::vector<float> reversed(xs.rbegin(), xs.rend()), shuffled = xs, sorted = xs;
    std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(29));
    std::sort(sorted.begin(), sorted.end());
    const ExactSum a = sumOf(xs), b = sumOf(reversed), c = sumOf(shuffled), d = sumOf(sorted);
    // Two partial sums (a split in the middle of the shuffled order) added together.
    ExactSum e = sumOf(std::vector<float>(shuffled.begin(), shuffled.begin() + 3777));
    e.add(sumOf(std::vector<float>(shuffled.begin() + 3777, shuffled.end())));
    CHECK(a == b);
    CHECK(a == c);
    CHECK(a == d);
    CHECK(a == e);
    for (const ExactSum* s : {&b, &c, &d, static_cast<const ExactSum*>(&e)}) CHECK(std::memcmp(&a, s, sizeof a) == 0);
    for (const ExactSum* s : {&b, &c, &d, static_cast<const ExactSum*>(&e)}) CHECK(s->value() == a.value());
    // The exact sum of the terms' exact values (each of these terms is >= 2^-41, so exact).
    i128 exact = 0;
    for (float x : xs) exact += reference(x);
    CHECK(a.v == exact);
    long double ld = 0;
    for (float x : sorted) ld += x;
    CHECK(a.value() == Approx(double(ld)).epsilon(1e-15));
    // The colour sum: channels are independent sums.
    ExactColorSum f, g;
    for (size_t i = 0; i + 2 < xs.size(); i += 3) f.add(Color(xs[i], xs[i + 1], xs[i + 2]));
    for (size_t i = xs.size() / 3 * 3; i >= 3; i -= 3) g.add(Color(xs[i - 3], xs[i - 2], xs[i - 1]));
    CHECK(f == g);
    CHECK(f.value() == g.value());
}

TEST_CASE("Film: samples and splats in any order or split across films give the same state", "[exact][film]") {
    const int passes = 5;
    const std::vector<Sample> samples = cameraSamples(passes, 41);
    const std::vector<Splat> sp = splats(passes, 43);
    const auto straight = render(samples, sp);

    // Reversed order.
    const auto reversed = render(std::vector<Sample>(samples.rbegin(), samples.rend()),
                                 std::vector<Splat>(sp.rbegin(), sp.rend()));
    CHECK(reversed->state() == straight->state());
    requireSameImage(reversed->develop(passes), straight->develop(passes));

    // Passes {0, 2, 4} on one film and {1, 3} on another, added (as the MPI reduction does).
    auto even = [](const auto& s) { return s.pass % 2 == 0; };
    auto odd = [](const auto& s) { return s.pass % 2 == 1; };
    auto a = render(where(samples, even), where(sp, even));
    const auto b = render(where(samples, odd), where(sp, odd));
    CHECK(a->state() != straight->state());
    a->addState(b->state());
    CHECK(a->state() == straight->state());
    requireSameImage(a->develop(passes), straight->develop(passes));

    // Three films, each pass modulo 3, added in two groupings: (p0 + p1) + p2 and p2 + (p1 + p0).
    auto mod3 = [](int r) { return [r](const auto& s) { return s.pass % 3 == r; }; };
    auto f0 = render(where(samples, mod3(0)), where(sp, mod3(0)));
    auto f1 = render(where(samples, mod3(1)), where(sp, mod3(1)));
    auto f2 = render(where(samples, mod3(2)), where(sp, mod3(2)));
    Film left(kW, kH, FilterType::Box);
    left.addState(f0->state()), left.addState(f1->state()), left.addState(f2->state());
    f1->addState(f0->state());
    f2->addState(f1->state());
    CHECK(left.state() == straight->state());
    CHECK(f2->state() == straight->state());
    CHECK(straight->state().size() == size_t(kW) * kH * Film::kBytesPerPixel + sizeof(uint64_t));
}

TEST_CASE("Film: invalid samples and splats are counted and added across films", "[exact][film]") {
    const std::vector<Sample> samples = cameraSamples(2, 51);
    const std::vector<Splat> sp = splats(2, 53);
    const auto clean = render(samples, sp);
    std::vector<Sample> dirty = samples;
    std::vector<Splat> dirtySp = sp;
    const float nan = std::nanf("");
    dirty.insert(dirty.begin() + 3, {0, 1, 1, Color(nan, 1.f, 1.f)});
    dirty.insert(dirty.begin() + 7, {0, 2, 3, Color(1.f, 1e30f, 1.f)});
    dirty.insert(dirty.begin() + 9, {1, 2, 3, Color(1.f, 1.f, 0x1p62f)});
    dirty.insert(dirty.begin() + 11, {1, 4, 0, Color(-1.f, 1.f, 1.f)});
    dirtySp.insert(dirtySp.begin() + 5, {0, Vec2(1.5f, 1.5f), Color(1e30f)});
    dirtySp.insert(dirtySp.begin() + 6, {1, Vec2(2.5f, 1.5f), Color(nan)});
    Film film(kW, kH, FilterType::Box);
    SplatBuffer buf;
    int rejected = 0;
    for (const Sample& s : dirty) rejected += !film.addSample(s.x, s.y, s.c);
    for (const Sample& s : samples) film.addSampleCount(s.x, s.y, 1);  // the invalid ones hold no count here
    for (const Splat& s : dirtySp) rejected += !film.splat(buf, s.raster, s.c);
    film.mergeSplats(buf);
    CHECK(rejected == 6);
    CHECK(film.invalidSamples() == 6);
    CHECK(clean->invalidSamples() == 0);
    // Nothing of the rejected ones was accumulated: the image is the clean one, and the states
    // differ only in the invalid count (the last 8 bytes).
    requireSameImage(film.develop(2), clean->develop(2));
    const std::string s = film.state(), c = clean->state();
    REQUIRE(s.size() == c.size());
    CHECK(s.substr(0, s.size() - 8) == c.substr(0, c.size() - 8));
    for (const Color& p : film.develop(2).pixels) CHECK(isFinite(p));
    // Invalid counts add across films.
    Film sum(kW, kH, FilterType::Box);
    sum.addState(film.state());
    sum.addState(film.state());
    CHECK(sum.invalidSamples() == 12);
}

TEST_CASE("Film: state and restore round-trip and a wrong size is refused", "[exact][film]") {
    const auto film = render(cameraSamples(3, 61), splats(3, 63));
    Film back(kW, kH, FilterType::Box);
    back.restore(film->state());
    CHECK(back.state() == film->state());
    requireSameImage(back.develop(3), film->develop(3));
    // Restoring replaces, addState adds: restore over a non-empty film is the saved film.
    auto other = render(cameraSamples(2, 65), splats(2, 67));
    other->restore(film->state());
    CHECK(other->state() == film->state());

    const std::string expected = std::to_string(size_t(kW) * kH * Film::kBytesPerPixel + sizeof(uint64_t));
    Film small(kW - 1, kH, FilterType::Box);
    using Catch::Matchers::Contains;
    CHECK_THROWS_WITH(back.restore(small.state()), Contains("expected " + expected));
    CHECK_THROWS_WITH(back.addState(small.state()), Contains("expected " + expected));
    CHECK_THROWS_AS(small.restore(film->state()), std::runtime_error);
    CHECK_THROWS_AS(back.addState(film->state() + "x"), std::runtime_error);
    CHECK_THROWS_AS(back.addState(std::string()), std::runtime_error);
    CHECK(back.state() == film->state());  // untouched by the refused ones
}

TEST_CASE("Film: develop is the double mean of the samples plus the splat sum over the passes", "[exact][film]") {
    const int passes = 7;
    const std::vector<Sample> samples = cameraSamples(passes, 71);
    const std::vector<Splat> sp = splats(passes, 73);
    const auto film = render(samples, sp);
    const Image img = film->develop(passes);
    std::vector<glm::dvec3> sum(size_t(kW) * kH, glm::dvec3(0.0)), splatSum = sum;
    std::vector<int> count(sum.size(), 0);
    for (const Sample& s : samples) sum[size_t(s.y) * kW + s.x] += glm::dvec3(s.c), ++count[size_t(s.y) * kW + s.x];
    for (const Splat& s : sp) splatSum[size_t(int(s.raster.y)) * kW + int(s.raster.x)] += glm::dvec3(s.c);
    // develop() gives floats: within half a float ulp (2^-24 relative) of the double mean.
    for (size_t i = 0; i < sum.size(); ++i) {
        const glm::dvec3 expect = sum[i] / double(count[i]) + splatSum[i] / double(passes);
        for (int k = 0; k < 3; ++k) CHECK(double(img.pixels[i][k]) == Approx(expect[k]).epsilon(0x1p-24));
    }
    // The doubles behind them, from the exact sums in the state (layout: camera sums, counts,
    // splat sums, invalid count): a double sum of 7 floats is within about 7 2^-53 of the exact
    // one, so 1e-12 relative.
    const std::string st = film->state();
    const size_t n = sum.size();
    for (size_t i = 0; i < n; ++i) {
        const glm::dvec3 expect = sum[i] / double(count[i]) + splatSum[i] / double(passes);
        ExactColorSum cam, spl;
        uint32_t c = 0;
        std::memcpy(&cam, st.data() + i * sizeof(ExactColorSum), sizeof cam);
        std::memcpy(&c, st.data() + n * sizeof(ExactColorSum) + i * sizeof(uint32_t), sizeof c);
        std::memcpy(&spl, st.data() + n * (sizeof(ExactColorSum) + sizeof(uint32_t)) + i * sizeof(ExactColorSum), sizeof spl);
        CHECK(c == uint32_t(count[i]));
        const glm::dvec3 got = cam.value() / double(c) + spl.value() / double(passes);
        for (int k = 0; k < 3; ++k) CHECK(got[k] == Approx(expect[k]).epsilon(1e-12));
    }
}
