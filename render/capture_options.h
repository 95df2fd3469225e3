// Parsers for the capture options a command line takes: an image size such
// as "800x600" and a frame list such as "0,512,1024,2047".
//
// They accept exactly those forms (decimal digits, spaces allowed around the
// list's items) and throw std::runtime_error quoting the whole text and the
// bad part, so a typo on the command line is reported, never guessed at.
#pragma once

#include <string_view>
#include <vector>

namespace overlap::render {

struct ImageSize {
  int width;
  int height;
  friend bool operator==(const ImageSize&, const ImageSize&) = default;
};

// "WIDTHxHEIGHT", both positive.
ImageSize parseImageSize(std::string_view text);

// Comma-separated frame numbers, each >= 0, none repeated; returned in
// ascending order.
std::vector<int> parseFrameList(std::string_view text);

}  // namespace overlap::render
