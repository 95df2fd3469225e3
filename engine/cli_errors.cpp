#include "engine/cli_errors.h"

namespace overlap::engine {
namespace {

std::string shownPath(const std::filesystem::path& path) {
  return path.empty() ? std::string("\"\"") : path.string();
}

}  // namespace

void prepareOutputDirectory(const std::filesystem::path& dir, std::string_view option) {
  if (const std::string problem = outputFolderProblem(dir); !problem.empty()) {
    throw UsageError(std::string(option) + " " + shownPath(dir) + ": " + problem);
  }
}

void prepareOutputFile(const std::filesystem::path& file, std::string_view option) {
  if (const std::string problem = outputFileProblem(file); !problem.empty()) {
    throw UsageError(std::string(option) + " " + shownPath(file) + ": " + problem);
  }
}

std::vector<std::filesystem::path> prepareOutputFiles(const std::filesystem::path& prefix,
                                                      const std::vector<std::string>& suffixes,
                                                      std::string_view option) {
  if (const std::string problem = outputNameProblem(prefix); !problem.empty()) {
    throw UsageError(std::string(option) + " " + shownPath(prefix) + ": " + problem);
  }
  std::vector<std::filesystem::path> files;
  for (const std::string& suffix : suffixes) {
    files.push_back(prefix);
    files.back() += suffix;
    prepareOutputFile(files.back(), option);
  }
  return files;
}

void declareOutput(OutputFolder& outputs, const std::filesystem::path& file,
                   std::string_view option) {
  if (const std::string problem = outputs.declare(file); !problem.empty()) {
    throw UsageError(std::string(option) + " " + shownPath(file) + ": " + problem);
  }
}

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
