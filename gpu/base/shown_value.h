// A value the user typed, as a message quotes it: whole up to 40 characters,
// else its first 20 and its length ("xxxxxxxxxxxxxxxxxxxx... (60000
// characters)").  Every message that echoes an option's value, a list's item
// or a word of the command line goes through it, so a refusal stays one
// readable line whatever was typed (a 100,000-character value was echoed
// whole).  Paths are not values: a message names them whole.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace overlap {

inline std::string shownValue(std::string_view text) {
  constexpr std::size_t kMostShown = 40;
  if (text.size() <= kMostShown) return std::string(text);
  return std::string(text.substr(0, kMostShown / 2)) + "... (" + std::to_string(text.size()) +
         " characters)";
}

}  // namespace overlap
