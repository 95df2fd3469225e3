#include "engine/program/number_options.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>

#include "gpu/base/shown_value.h"

namespace overlap::engine {
namespace {

std::string shown(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

// The numbers' spellings, read by hand: std::regex matches recursively, a
// frame per character, and a value of some 50,000 digits overflowed the
// stack (a crash where a refusal was due).
class Spelling {
 public:
  explicit Spelling(const std::string& text) : text_(text) {}
  bool sign() { return take("+-"); }
  bool take(std::string_view any) {
    if (at_ < text_.size() && any.find(text_[at_]) != std::string_view::npos) {
      ++at_;
      return true;
    }
    return false;
  }
  std::size_t digits() {  // how many were taken
    const std::size_t start = at_;
    while (at_ < text_.size() && text_[at_] >= '0' && text_[at_] <= '9') ++at_;
    return at_ - start;
  }
  bool wholePart() {  // "0" or a digit 1-9 and more: "010" would be read as octal
    if (take("0")) return true;
    return take("123456789") && (digits(), true);
  }
  bool exponent() {  // nothing, or [eE][+-]?[0-9]+
    if (!take("eE")) return true;
    sign();
    return digits() > 0;
  }
  bool ended() const { return at_ == text_.size(); }

 private:
  const std::string& text_;
  std::size_t at_ = 0;
};

bool isWhole(const std::string& text) {
  Spelling spelling(text);
  spelling.sign();
  return spelling.wholePart() && spelling.ended();
}

bool isDecimal(const std::string& text) {
  // "010" and "00.5" are refused as whole numbers are: a leading zero only before '.' or alone.
  Spelling spelling(text);
  spelling.sign();
  if (spelling.wholePart()) {
    if (spelling.take(".")) spelling.digits();
  } else if (!spelling.take(".") || spelling.digits() == 0) {
    return false;
  }
  return spelling.exponent() && spelling.ended();
}

// "010", "-007.5": a number written with a leading zero (which some readers
// take as octal), refused with a message of its own.
bool hasLeadingZero(const std::string& text) {
  Spelling spelling(text);
  spelling.sign();
  if (!spelling.take("0") || spelling.digits() == 0) return false;
  if (spelling.take(".")) spelling.digits();
  return spelling.exponent() && spelling.ended();
}

std::string leadingZeroProblem(const std::string& text) {
  return shownValue(text) + " has a leading zero (write it without)";
}

// "" when `text` is a whole number in [lo, hi], else the message.
template <typename Int>
std::string wholeProblem(const std::string& text, Int lo, Int hi) {
  if (text.empty()) return "an empty value is not a number";
  if (hasLeadingZero(text)) return leadingZeroProblem(text);
  if (!isWhole(text)) return shownValue(text) + " is not a whole number";
  const bool negative = text[0] == '-';
  const std::string digits = text.substr(text[0] == '+' || negative ? 1 : 0);
  std::uint64_t magnitude = 0;
  const auto [end, error] =
      std::from_chars(digits.data(), digits.data() + digits.size(), magnitude);
  const bool huge = error == std::errc::result_out_of_range;
  if (negative && magnitude != 0) {
    // Below any lo >= 0; otherwise compared as a signed number.
    if constexpr (std::is_unsigned_v<Int>)
      return shownValue(text) + " must be at least " + std::to_string(lo);
    if (huge || magnitude > static_cast<std::uint64_t>(std::numeric_limits<Int>::max()) ||
        -static_cast<std::int64_t>(magnitude) < static_cast<std::int64_t>(lo)) {
      return shownValue(text) + " must be at least " + std::to_string(lo);
    }
    return "";
  }
  if (huge || magnitude > static_cast<std::uint64_t>(hi)) {
    return shownValue(text) + " must be at most " + std::to_string(hi);
  }
  if (magnitude < static_cast<std::uint64_t>(std::max<Int>(lo, 0))) {
    return shownValue(text) + " must be at least " + std::to_string(lo);
  }
  return "";
}

}  // namespace

std::string wholeNumberProblem(const std::string& text, std::int64_t lo, std::int64_t hi) {
  return wholeProblem<std::int64_t>(text, lo, hi);
}

CLI::Validator wholeNumberIn(std::int64_t lo, std::int64_t hi) {
  return CLI::Validator(
      [lo, hi](std::string& text) { return wholeProblem<std::int64_t>(text, lo, hi); },
      std::to_string(lo) + ".." + std::to_string(hi));
}

CLI::Validator seedNumber() {
  return CLI::Validator(
      [](std::string& text) {
        return wholeProblem<std::uint64_t>(text, 0, std::numeric_limits<std::uint64_t>::max());
      },
      "0..2^64-1");
}

CLI::Validator realNumberIn(double lo, double hi, bool above_lo) {
  return CLI::Validator(
      [lo, hi, above_lo](std::string& text) -> std::string {
        if (text.empty()) return "an empty value is not a number";
        if (hasLeadingZero(text)) return leadingZeroProblem(text);
        if (!isDecimal(text)) {
          const double value = std::strtod(text.c_str(), nullptr);
          return shownValue(text) + (std::isnan(value) || std::isinf(value)
                                         ? " is not a finite number"
                                         : " is not a number");
        }
        errno = 0;
        const double value = std::strtod(text.c_str(), nullptr);
        if (errno == ERANGE && std::abs(value) > 1)
          return shownValue(text) + " must be at most " + shown(hi);
        if (above_lo && !(value > lo)) return shownValue(text) + " must be above " + shown(lo);
        if (value < lo) return shownValue(text) + " must be at least " + shown(lo);
        if (value > hi) return shownValue(text) + " must be at most " + shown(hi);
        return "";
      },
      (above_lo ? "(" : "[") + shown(lo) + ", " + shown(hi) + "]");
}

}  // namespace overlap::engine
