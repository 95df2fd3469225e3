// The check for an option that takes one of a few names (--algo, --colour):
// a value outside them is refused as "VALUE is not one of a, b, c", the value
// shown as gpu/base/shown_value.h shows it.  (CLI11's IsMember echoed any
// value whole: a 100,000-character --algo made a 100,000-character line.)
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace overlap::engine {

CLI::Validator oneOf(std::vector<std::string> names);

}  // namespace overlap::engine
