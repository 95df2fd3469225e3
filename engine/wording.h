// Counts in messages: "1 frame", "2 frames", "1 PNG", "4 PNGs".
#pragma once

#include <string>
#include <string_view>

namespace overlap::engine {

// `count` and `noun`, with an 's' unless the count is one.
inline std::string counted(long long count, std::string_view noun) {
  return std::to_string(count) + ' ' + std::string(noun) + (count == 1 ? "" : "s");
}

}  // namespace overlap::engine
