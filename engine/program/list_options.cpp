#include "engine/program/list_options.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "gpu/base/shown_value.h"

namespace overlap::engine {
namespace {

std::string_view trimmed(std::string_view text) {
  const auto first = text.find_first_not_of(' ');
  if (first == std::string_view::npos) return {};
  return text.substr(first, text.find_last_not_of(' ') - first + 1);
}

// The first name of `name` ("--objects,-n" -> "--objects"), for messages.
std::string shownName(const std::string& name) {
  return name.substr(0, name.find(','));
}

template <typename T>
T converted(const std::string& text) {
  if constexpr (std::is_same_v<T, std::string>) {
    return text;
  } else if constexpr (std::is_floating_point_v<T>) {
    return static_cast<T>(std::strtod(text.c_str(), nullptr));
  } else {
    return static_cast<T>(std::strtoll(text.c_str(), nullptr, 10));
  }
}

template <typename T>
std::string defaultText(const T& value) {
  if constexpr (std::is_same_v<T, std::string>) {
    return value;
  } else {
    return CLI::detail::to_string(value);
  }
}

}  // namespace

template <typename T>
std::vector<T> parseList(const std::string& option, const std::vector<std::string>& texts,
                         CLI::Validator item) {
  std::vector<T> values;
  std::vector<std::string> given;  // each item as typed, for messages
  for (const std::string& text : texts) {
    std::string_view rest = text;
    for (;;) {
      const auto comma = rest.find(',');
      std::string entry(trimmed(rest.substr(0, comma)));
      if (entry.empty()) {
        throw CLI::ValidationError(shownName(option),
                                   "\"" + shownValue(text) +
                                       "\" has an empty item (items are separated by "
                                       "single commas)");
      }
      if (const std::string problem = item(entry); !problem.empty()) {
        throw CLI::ValidationError(shownName(option), problem);
      }
      const T value = converted<T>(entry);
      if (const auto same = std::find(values.begin(), values.end(), value); same != values.end()) {
        const std::string& first = given[static_cast<std::size_t>(same - values.begin())];
        throw CLI::ValidationError(shownName(option),
                                   shownValue(entry) +
                                       (entry == first ? "" : " (" + shownValue(first) + ")") +
                                       " is listed twice");
      }
      values.push_back(value);
      given.push_back(entry);
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
  }
  return values;
}

template <typename T>
CLI::Option* addListOption(CLI::App& command, const std::string& name, std::vector<T>& values,
                           CLI::Validator item, const std::string& description) {
  std::string shown;
  for (const T& value : values) shown += (shown.empty() ? "" : ",") + defaultText(value);
  CLI::Option* option = command.add_option_function<std::vector<std::string>>(
      name,
      [&values, name, item](const std::vector<std::string>& texts) {
        values = parseList<T>(name, texts, item);
      },
      description);
  return option->type_name("LIST")->default_str(shown);
}

template std::vector<int> parseList<int>(const std::string&, const std::vector<std::string>&,
                                         CLI::Validator);
template std::vector<double> parseList<double>(const std::string&, const std::vector<std::string>&,
                                               CLI::Validator);
template std::vector<std::string> parseList<std::string>(const std::string&,
                                                         const std::vector<std::string>&,
                                                         CLI::Validator);
template CLI::Option* addListOption<int>(CLI::App&, const std::string&, std::vector<int>&,
                                         CLI::Validator, const std::string&);
template CLI::Option* addListOption<double>(CLI::App&, const std::string&, std::vector<double>&,
                                            CLI::Validator, const std::string&);
template CLI::Option* addListOption<std::string>(CLI::App&, const std::string&,
                                                 std::vector<std::string>&, CLI::Validator,
                                                 const std::string&);

}  // namespace overlap::engine
