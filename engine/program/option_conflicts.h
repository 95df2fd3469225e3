// Options that must not be given together, refused once parsing is done and
// before any work, as one UsageError naming both as the user typed them.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <string_view>

#include "engine/program/usage_error.h"

namespace overlap::engine {

// "--size": an option's name as the user typed it, hidden options included.
std::string optionName(const CLI::Option* option);

// Throws UsageError naming both options when both were given: they
// conflict, or the first would be ignored (`why` says which).
void refuseTogether(const CLI::Option* first, const CLI::Option* second, std::string_view why);

}  // namespace overlap::engine
