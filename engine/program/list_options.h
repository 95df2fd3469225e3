// The one parser of every option that takes a list (docs/CLI.md, "Lists"):
// the benchmark's --objects, --big-objects, --algos, --big-algos and
// --churn, latency's --algo and --growth, capture's --keyframes.
//
//   * Items are separated by commas (a list may also be given as several
//     values or repeated options); spaces around an item are dropped.
//   * Every item passes the item's check (engine/program/number_options.h for
//     numbers: no leading zeros, no hex; the broadphase names for --algo):
//     the whole list is the user's, nothing is guessed.
//   * An empty item ("1,,2", "bvh,", "") or an item given twice ("0,0",
//     "0.1,0.10") is refused: CLI11 would drop the first silently and a
//     repeated item gives repeated rows.
// Refusals are CLI::ValidationErrors naming the option, so they exit 2
// before any work, as any bad value does.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace overlap::engine {

// The items of `texts` (each a comma-separated list), each checked by
// `item` and converted; throws CLI::ValidationError naming `option`.
template <typename T>
std::vector<T> parseList(const std::string& option, const std::vector<std::string>& texts,
                         CLI::Validator item);

// Registers `name` as a list option filling `values` (its default shown).
template <typename T>
CLI::Option* addListOption(CLI::App& command, const std::string& name, std::vector<T>& values,
                           CLI::Validator item, const std::string& description);

}  // namespace overlap::engine
