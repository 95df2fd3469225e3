// Strict checks for the numbers the command line takes (docs/CLI.md,
// "Bounds").  Each accepts plain decimal text only, in the option's
// documented bounds, and refuses anything else with a short message that
// CLI11 prefixes with the option's name:
//   --objects 0x10      "0x10 is not a whole number"
//   --growth nan        "nan is not a finite number"
//   --wall-min 0        "0 must be above 0"
//   --seed -1           "-1 must be at least 0"
// Hex, leading zeros (CLI11 would read them as octal), NaN, infinities, empty text and values
// beyond the bound never reach the program.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

namespace overlap::engine {

// The upper bound of a real option that has no natural one.
inline constexpr double kMostReal = 1e6;

// A whole number in [lo, hi] (decimal digits, no leading zero, an optional sign).
CLI::Validator wholeNumberIn(std::int64_t lo, std::int64_t hi);
// The same check for an option that also takes words (--substeps auto|K):
// "" when `text` is such a number, else the message.
std::string wholeNumberProblem(const std::string& text, std::int64_t lo, std::int64_t hi);
// A seed: a whole number in [0, 2^64 - 1].
CLI::Validator seedNumber();
// A finite decimal number in [lo, hi], or (lo, hi] when `above_lo`.
CLI::Validator realNumberIn(double lo, double hi, bool above_lo = false);

}  // namespace overlap::engine
