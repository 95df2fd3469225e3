// Counts in messages: "1 frame", "2 frames", "1 PNG", "4 PNGs".
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace overlap::engine {

// `count` and `noun`, with an 's' unless the count is one.
inline std::string counted(long long count, std::string_view noun) {
  return std::to_string(count) + ' ' + std::string(noun) + (count == 1 ? "" : "s");
}

// "; removed the last run's a.png, b.png and 3 more": the end of the line
// naming what a run wrote, naming the first few files a run folder's commit removed; empty
// when it removed none.
inline std::string removedText(const std::vector<std::string>& removed) {
  constexpr std::size_t kNamed = 5;
  if (removed.empty()) return {};
  std::string text = "; removed the last run's ";
  const std::size_t named = removed.size() <= kNamed + 1 ? removed.size() : kNamed;
  for (std::size_t i = 0; i < named; ++i) {
    text += (i == 0 ? "" : (i + 1 == named && named == removed.size() ? " and " : ", "));
    text += removed[i];
  }
  if (named < removed.size()) text += " and " + std::to_string(removed.size() - named) + " more";
  return text;
}

}  // namespace overlap::engine
