// The parser of the image size a command line takes, such as "800x600"
// (the frame lists are engine/program/list_options.h's).
//
// It accepts exactly that form (decimal digits, no leading zero, no sign but
// a '+', which every whole-number option also takes)
// and throws std::runtime_error quoting the whole text and the bad part, so
// a typo on the command line is reported, never guessed at; a number too
// large for an int is said to be out of range.
#pragma once

#include <string_view>

namespace overlap::render {

struct ImageSize {
  int width;
  int height;
  friend bool operator==(const ImageSize&, const ImageSize&) = default;
};

// "WIDTHxHEIGHT", both positive.
ImageSize parseImageSize(std::string_view text);

}  // namespace overlap::render
