#include "engine/program/summary_output.h"

#include <cstdio>

namespace overlap::engine {

void addQuietFlag(CLI::App& command, bool& quiet) {
  command.add_flag("--quiet", quiet, "print no summary at the end (the rest is printed as ever)")
      ->default_str("off");
}

void printSummary(bool quiet, const std::string& title, const std::vector<std::string>& lines) {
  if (quiet) return;
  std::string text = title + '\n';
  for (const std::string& line : lines) text += "  " + line + '\n';
  std::fputs(text.c_str(), stderr);
}

}  // namespace overlap::engine
