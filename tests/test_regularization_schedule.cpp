// JG19 Eq. 16, the consistent roughness bound tau_N (bsdf/roughness_bound.h, consistentTau).
// Deterministic: every check is a closed-form property, no sampling.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include "bsdf/roughness_bound.h"

using namespace lt;

namespace {

// Eq. 16 exactly as printed, in long double (64-bit mantissa on x86). Its 1 - cos(atan(y)) cancels
// about log2(1/y^2) bits, so it is a trustworthy reference only while y^2 is not tiny: the
// comparison below uses it for y^2 >= 1e-8 (<= 27 bits lost: ~1e-11 relative), and the
// asymptotic series covers the range beyond.
long double literalTau(long double tau0, long double n) {
    const long double pi = 3.141592653589793238462643383279502884L;
    const long double x = std::sqrt(4.0L * pi * tau0 - 1.0L) / (2.0L * pi * tau0 - 1.0L);
    return 1.0L / (2.0L * pi * (1.0L - std::cos(std::atan(x * std::pow(n, -1.0L / 6.0L)))));
}

long double ySquared(long double tau0, long double n) {
    const long double pi = 3.141592653589793238462643383279502884L;
    const long double k = 2.0L * pi * tau0 - 1.0L;
    return (4.0L * pi * tau0 - 1.0L) / (k * k) / std::cbrt(n);
}

}  // namespace

TEST_CASE("tau_N (JG19 Eq. 16): tau_1 = tau_0", "[regularization][tau]") {
    for (double tau0 : {0.2, 0.5, 1.0, 10.0, 30.0, 1000.0, 1e6, 1e12, 1e30}) {
        INFO("tau0 = " << tau0);
        // 2 pi tau0 = 1.26 for tau0 = 0.2: the closest to the domain's edge tested here.
        CHECK(consistentTau(tau0, 1) == Approx(tau0).epsilon(1e-13));
    }
}

TEST_CASE("tau_N (JG19 Eq. 16): equals the printed formula in long double", "[regularization][tau]") {
    int compared = 0;
    for (double tau0 : {0.2, 1.0, 10.0, 30.0, 1000.0, 1e5}) {
        for (double n = 1; n <= 1e12; n *= 7.3) {
            const auto nn = uint64_t(n);
            if (ySquared(tau0, (long double)nn) < 1e-8L) continue;  // literal form unresolvable
            const long double ref = literalTau(tau0, (long double)nn);
            const double got = consistentTau(tau0, nn);
            INFO("tau0 = " << tau0 << ", n = " << nn);
            // long double literal: ~2^-64 / y^2 <= 5e-12 relative; ours a few ulp: 1e-10 has margin.
            CHECK(std::abs(double((got - ref) / ref)) < 1e-10);
            ++compared;
        }
    }
    CHECK(compared > 60);  // the filter must not empty the test
}

TEST_CASE("tau_N (JG19 Eq. 16): strictly increasing, finite to N = 1e12, grows like N^(1/3)", "[regularization][tau]") {
    const double pi = 3.14159265358979323846;
    for (double tau0 : {0.2, 30.0, 1000.0, 1e6}) {
        INFO("tau0 = " << tau0);
        double prev = consistentTau(tau0, 1);
        for (uint64_t n = 2; n <= 2000; ++n) {
            const double t = consistentTau(tau0, n);
            REQUIRE(t > prev);
            prev = t;
        }
        for (double n = 3000; n <= 1e12; n *= 1.5) {
            const double t = consistentTau(tau0, uint64_t(n));
            REQUIRE(std::isfinite(t));
            REQUIRE(t > prev);
            prev = t;
        }
        // Asymptote: tau_N -> N^(1/3) / (pi x^2) (+ 3/(4 pi) + O(N^(-1/3))): the ratio at N = 1e12
        // differs from 1 by about pi x^2 3/(4 pi) N^(-1/3) = 0.75 x^2 1e-4 <= 3e-4 for these tau0.
        const double k = 2.0 * pi * tau0 - 1.0;
        const double x2 = (4.0 * pi * tau0 - 1.0) / (k * k);
        const double ratio = consistentTau(tau0, uint64_t(1e12)) / (std::cbrt(1e12) / (pi * x2));
        CHECK(ratio > 1.0);
        CHECK(ratio - 1.0 < 0.76 * x2 * 1e-4 + 1e-12);
    }
}

TEST_CASE("tau_N (JG19 Eq. 16): double without cancellation where the literal double form fails", "[regularization][tau]") {
    // tau0 = 1e6, N = 1e12: y^2 = 1.6e-11 and 1 - cos(atan y) in double keeps ~5 digits; the
    // literal double evaluation is off by > 1e-7 relative, ours agrees with the asymptotic series
    // tau = 1/(pi y^2) + 3/(4 pi) + O(y^2) (exact to ~1e-11 relative here) within 1e-12.
    const double pi = 3.14159265358979323846;
    const double tau0 = 1e6;
    const uint64_t n = uint64_t(1e12);
    const double k = 2.0 * pi * tau0 - 1.0;
    const double y2 = (4.0 * pi * tau0 - 1.0) / (k * k) / std::cbrt(double(n));
    const double series = 1.0 / (pi * y2) + 3.0 / (4.0 * pi);
    const double naive = 1.0 / (2.0 * pi * (1.0 - std::cos(std::atan(std::sqrt(y2)))));
    CHECK(std::abs(naive / series - 1.0) > 1e-7);  // the cancellation this function avoids
    CHECK(std::abs(consistentTau(tau0, n) / series - 1.0) < 1e-12);
}

TEST_CASE("tau_N (JG19 Eq. 16): bad arguments", "[regularization][tau]") {
    CHECK_THROWS_AS(consistentTau(30.0, 0), std::invalid_argument);
    CHECK_THROWS_AS(consistentTau(0.15, 1), std::invalid_argument);  // below 1/(2 pi)
    CHECK_THROWS_AS(consistentTau(-1.0, 5), std::invalid_argument);
    CHECK_THROWS_AS(consistentTau(std::nan(""), 5), std::invalid_argument);
    CHECK(std::isinf(consistentTau(std::numeric_limits<double>::infinity(), 7)));
    CHECK(std::isfinite(consistentTau(1e300, uint64_t(1e12))));
}
