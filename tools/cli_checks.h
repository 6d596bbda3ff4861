// Range checks of the command-line tools' numeric options that say the valid range in words:
// "--spp: must be greater than 0 (got -3)" where CLI11's own checks print the bounds as numbers,
// DBL_MAX written out in full among them. Each returns a CLI11 validator (CLI11 prefixes the
// option's name); a value that is not a number is named as such.
#pragma once
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <string>
#include "tools/parse_number.h"

namespace lt::cli {

namespace detail {

// A validator accepting the numbers x with ok(x), else "must be <what> (got s)".
template <class Ok>
CLI::Validator check(const std::string& what, Ok ok) {
    return CLI::Validator(
        [what, ok](std::string& s) -> std::string {
            double v = 0.0;
            if (!parseFiniteNumber(s, v)) return fmt::format("must be a number, {} (got '{}')", what, s);
            return ok(v) ? std::string() : fmt::format("must be {} (got {})", what, s);
        },
        what);
}

}  // namespace detail

// x > 0.
inline CLI::Validator positive() {
    return detail::check("greater than 0", [](double v) { return v > 0.0; });
}
// x >= 0 (`meaning`, e.g. "0 = all cores", is added in parentheses).
inline CLI::Validator nonNegative(const std::string& meaning = "") {
    const std::string what = meaning.empty() ? "0 or more" : fmt::format("0 or more ({})", meaning);
    return detail::check(what, [](double v) { return v >= 0.0; });
}
// x > lo (`loName` names lo, e.g. "1/(2 pi) = 0.159").
inline CLI::Validator greaterThan(double lo, const std::string& loName) {
    return detail::check(fmt::format("greater than {}", loName), [lo](double v) { return v > lo; });
}
// lo <= x <= hi, or with an open end: (lo, hi], [lo, hi). `note` is added in parentheses.
inline CLI::Validator range(double lo, double hi, bool loOpen = false, bool hiOpen = false, const std::string& note = "") {
    std::string what = fmt::format("in {}{:g}, {:g}{}", loOpen ? "(" : "[", lo, hi, hiOpen ? ")" : "]");
    if (!note.empty()) what += " (" + note + ")";
    return detail::check(what, [=](double v) {
        return (loOpen ? v > lo : v >= lo) && (hiOpen ? v < hi : v <= hi);
    });
}

}  // namespace lt::cli
