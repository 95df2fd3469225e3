#include "render/capture_options.h"

#include <algorithm>
#include <charconv>
#include <optional>
#include <stdexcept>
#include <string>

namespace overlap::render {
namespace {

std::string_view trimSpaces(std::string_view text) {
  const auto first = text.find_first_not_of(' ');
  if (first == std::string_view::npos) return {};
  return text.substr(first, text.find_last_not_of(' ') - first + 1);
}

// The whole of text as a non-negative int, or nothing.
std::optional<int> parseNonNegative(std::string_view text) {
  int value = 0;
  const char* end = text.data() + text.size();
  if (text.empty() || text.front() < '0' || text.front() > '9') return std::nullopt;
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  if (error != std::errc() || stop != end) return std::nullopt;
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
  const auto width = parseNonNegative(width_text);
  const auto height = parseNonNegative(height_text);
  if (!width || *width == 0) {
    throw std::runtime_error(quoted + ": width \"" + std::string(width_text) +
                             "\" is not a positive integer");
  }
  if (!height || *height == 0) {
    throw std::runtime_error(quoted + ": height \"" + std::string(height_text) +
                             "\" is not a positive integer");
  }
  return {*width, *height};
}

std::vector<int> parseFrameList(std::string_view text) {
  const std::string quoted = "frame list \"" + std::string(text) + "\"";
  std::vector<int> frames;
  std::string_view rest = text;
  for (;;) {
    const auto comma = rest.find(',');
    const std::string_view item = trimSpaces(rest.substr(0, comma));
    const auto frame = parseNonNegative(item);
    if (!frame) {
      throw std::runtime_error(quoted + ": \"" + std::string(item) +
                               "\" is not a frame number (an integer >= 0)");
    }
    if (std::find(frames.begin(), frames.end(), *frame) != frames.end()) {
      throw std::runtime_error(quoted + ": frame " + std::to_string(*frame) + " is listed twice");
    }
    frames.push_back(*frame);
    if (comma == std::string_view::npos) break;
    rest.remove_prefix(comma + 1);
  }
  std::sort(frames.begin(), frames.end());
  return frames;
}

}  // namespace overlap::render
