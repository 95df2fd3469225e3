#include "render/capture_options.h"

#include <charconv>
#include <limits>
#include <stdexcept>
#include <string>

namespace overlap::render {
namespace {

// `text` without the one '+' it may open with, as every whole-number option
// reads it (engine/program/number_options.h).
std::string_view unsigned_part(std::string_view text) {
  return text.starts_with('+') ? text.substr(1) : text;
}

// "" when `text` is a positive int, else what is wrong with it.
std::string positiveProblem(std::string_view signed_text) {
  std::string quoted = "\"";  // appended: GCC 12 warns falsely on "\"" + string (-Wrestrict)
  quoted += signed_text;
  quoted += '"';
  const std::string_view text = unsigned_part(signed_text);
  const bool digits =
      !text.empty() && text.find_first_not_of("0123456789") == std::string_view::npos;
  if (!digits || text.front() == '0') {
    return quoted + " is not a positive integer (decimal, no leading zero)";
  }
  int value = 0;
  const auto [stop, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error == std::errc::result_out_of_range) {
    return quoted + " is out of range (at most " + std::to_string(std::numeric_limits<int>::max()) +
           ")";
  }
  return {};
}

int positive(std::string_view signed_text) {
  const std::string_view text = unsigned_part(signed_text);
  int value = 0;
  std::from_chars(text.data(), text.data() + text.size(), value);
  return value;
}

}  // namespace

ImageSize parseImageSize(std::string_view text) {
  const std::string quoted = "image size \"" + std::string(text) + "\"";
  const auto separator = text.find('x');
  if (separator == std::string_view::npos) {
    throw std::runtime_error(quoted + " is not WIDTHxHEIGHT, e.g. 800x600");
  }
  const std::string_view width_text = text.substr(0, separator);
  const std::string_view height_text = text.substr(separator + 1);
  if (const std::string problem = positiveProblem(width_text); !problem.empty()) {
    throw std::runtime_error(quoted + ": width " + problem);
  }
  if (const std::string problem = positiveProblem(height_text); !problem.empty()) {
    throw std::runtime_error(quoted + ": height " + problem);
  }
  return {positive(width_text), positive(height_text)};
}

}  // namespace overlap::render
