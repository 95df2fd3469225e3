#include "engine/program/option_conflicts.h"

namespace overlap::engine {

std::string optionName(const CLI::Option* option) {
  if (!option->get_lnames().empty()) return "--" + option->get_lnames().front();
  if (!option->get_snames().empty()) return "-" + option->get_snames().front();
  return option->get_name(false, true);
}

void refuseTogether(const CLI::Option* first, const CLI::Option* second, std::string_view why) {
  if (first->count() > 0 && second->count() > 0) {
    throw UsageError(optionName(first) + " and " + optionName(second) + ": " + std::string(why));
  }
}

}  // namespace overlap::engine
