// How the project writes CSV (the benchmark's results, latency's and
// pairs' rows, frames.csv): one place for the rules, so a name from the
// user (a stream's path, a command line) can never add a column or a line.
//   * A field is written as RFC 4180 says: as it is, unless it holds a
//     comma, a double quote, a CR or an LF; then in double quotes, each
//     double quote doubled.
//   * A comment line ("# ...", above the header) stays one line: CR and LF
//     inside it are written as \r and \n.
//   * A number the user gave (a churn share) is written so it reads back
//     as the same double (the shortest such text), never rounded to a
//     fixed count of decimals.
#pragma once

#include <string>
#include <string_view>

namespace overlap::engine {

std::string csvField(std::string_view text);
// "# text\n", one line.
std::string csvComment(std::string_view text);
// The shortest text that reads back as `value`, with an exponent only where
// the plain decimal would be longer than 24 characters ("0.0004", "1000",
// "1e-300").
std::string exactNumber(double value);

}  // namespace overlap::engine
