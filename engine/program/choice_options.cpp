#include "engine/program/choice_options.h"

#include <algorithm>
#include <utility>

#include "gpu/base/shown_value.h"

namespace overlap::engine {

CLI::Validator oneOf(std::vector<std::string> names) {
  std::string listed;  // "a, b, c" for messages; the help shows CLI11's "{a,b,c}"
  std::string braced;
  for (const std::string& name : names) {
    listed += (listed.empty() ? "" : ", ") + name;
    braced += (braced.empty() ? "" : ",") + name;
  }
  return CLI::Validator(
      [names = std::move(names), listed](const std::string& text) -> std::string {
        if (std::find(names.begin(), names.end(), text) != names.end()) return {};
        return (text.empty() ? std::string("an empty value") : shownValue(text)) +
               " is not one of " + listed;
      },
      "{" + braced + "}");
}

}  // namespace overlap::engine
