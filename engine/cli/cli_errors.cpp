#include "engine/cli/cli_errors.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <iterator>
#include <new>
#include <regex>

#include "gpu/base/interrupt.h"
#include "gpu/base/output_file.h"

namespace overlap::engine {
namespace {

std::string shownPath(const std::filesystem::path& path) {
  return path.empty() ? std::string("\"\"") : path.string();
}

// CLI11's words for a parse error, in the project's where they are its
// own jargon: "--objects: At Most 1 required but received 2".
std::string parseErrorText(const CLI::ParseError& error) {
  static const std::regex kRepeated("^(.*): At Most 1 required but received ([0-9]+)$");
  std::smatch match;
  const std::string text = error.what();
  if (std::regex_match(text, match, kRepeated)) {
    return match[1].str() + " is given " + match[2].str() + " times; give it once";
  }
  return text;
}

void printError(const char* program, std::string_view message) {
  std::fprintf(stderr, "%s: %s\n", program, oneLine(message).c_str());
}

// 0 when everything written to standard output reached it, else 1 with the
// message naming it.
int flushStandardOutput(const char* program) {
  std::cout.flush();
  errno = 0;
  if (std::fflush(stdout) == 0 && std::ferror(stdout) == 0 && std::cout.good()) return 0;
  // errno is the flush's; a write that failed earlier left no reason.
  printError(program, std::string("error: standard output: cannot write") +
                          (errno != 0 ? std::string(": ") + std::strerror(errno) : ""));
  return 1;
}

// "out of memory: WHAT (ulimit -v or the machine's memory)", advising
// --max-memory only to a command that has it and was not given it.
std::string outOfMemoryText(const CLI::App& app, const std::bad_alloc& error) {
  const std::string what = error.what();
  std::string text =
      "out of memory: " +
      (what == std::bad_alloc().what() ? std::string("an allocation failed") : what) +
      " (ulimit -v or the machine's memory)";
  const CLI::App* command = &app;
  for (const CLI::App* chosen = &app; chosen != nullptr;) {
    command = chosen;
    const std::vector<CLI::App*> parsed = chosen->get_subcommands();  // those given
    chosen = parsed.empty() ? nullptr : parsed.front();
  }
  const CLI::Option* limit = nullptr;
  try {
    limit = command->get_option("--max-memory");
  } catch (const CLI::OptionNotFound&) {
  }
  if (limit != nullptr && limit->count() == 0) {
    text += "; a --max-memory below what it can allocate refuses such a run before it allocates";
  }
  return text;
}

}  // namespace

std::string oneLine(std::string_view message) {
  std::string line;
  for (const char c : message) {
    const auto byte = static_cast<unsigned char>(c);
    if (c == '\n') {
      line += "\\n";
    } else if (c == '\r') {
      line += "\\r";
    } else if (byte < 0x20 || byte == 0x7f) {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02x", byte);
      line += escaped;
    } else {
      line += c;
    }
  }
  return line;
}

int runProgram(const char* program, CLI::App& app, const std::function<int()>& body) {
  int code = 0;
  try {
    code = body();
  } catch (const CLI::Success& help_or_version) {
    code = app.exit(help_or_version);
  } catch (const CLI::ParseError& error) {
    printError(program, parseErrorText(error) + " (see --help)");
    code = 2;
  } catch (const UsageError& error) {
    printError(program, error.what());
    code = 2;
  } catch (const Interrupted& stop) {
    code = reportInterrupted(program, stop);
  } catch (const std::bad_alloc& error) {
    printError(program, outOfMemoryText(app, error));
    code = 1;
  } catch (const std::exception& error) {
    // A thread whose stack cannot be mapped (ulimit -v) is memory run out.
    const bool no_thread = std::string_view(error.what()).starts_with("pthread_create has failed");
    printError(program, no_thread ? "out of memory: a thread could not be started (" +
                                        std::string(error.what()) +
                                        "; ulimit -v, the machine's memory or its threads)"
                                  : std::string("error: ") + error.what());
    code = 1;
  }
  const int flushed = flushStandardOutput(program);
  return code == 0 ? flushed : code;
}

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

void requireFreeSpace(const std::filesystem::path& file, std::uint64_t bytes,
                      std::string_view option) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(file, error);
  if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status)) return;
  // The folder it goes to, or the nearest one that exists (made by the run).
  const std::filesystem::path folder =
      nearestExisting(std::filesystem::absolute(file, error).parent_path());
  const std::filesystem::space_info space = std::filesystem::space(folder, error);
  if (error) return;  // unknown here: a full disk is then reported by the write
  if (bytes > space.available) {
    throw UsageError(std::string(option) + " " + shownPath(file) + ": needs " +
                     readableBytes(bytes) + ", and its folder has " +
                     readableBytes(space.available) + " free");
  }
}

std::string readableBytes(std::uint64_t bytes) {
  static constexpr const char* kUnits[] = {"bytes", "kB", "MB", "GB", "TB", "PB", "EB"};
  auto value = static_cast<double>(bytes);
  std::size_t unit = 0;
  while (value >= 1000 && unit + 1 < std::size(kUnits)) {
    value /= 1000;
    ++unit;
  }
  char text[32];
  std::snprintf(text, sizeof(text), unit == 0 ? "%.0f %s" : "%.1f %s", value, kUnits[unit]);
  return text;
}

std::vector<std::filesystem::path> prepareOutputFiles(const std::filesystem::path& prefix,
                                                      const std::vector<std::string>& suffixes,
                                                      std::string_view option) {
  if (const std::string problem = outputNameProblem(prefix); !problem.empty()) {
    throw UsageError(std::string(option) + " " + shownPath(prefix) + ": " + problem);
  }
  // The prefix itself is never written: its files go beside it, so a
  // device, FIFO or socket there (/dev/null) is a name mistaken for a file.
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(prefix, error);
  if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status) &&
      !std::filesystem::is_directory(status)) {
    throw UsageError(std::string(option) + " " + shownPath(prefix) +
                     ": is a device, FIFO or socket, not a prefix of files (its files would be "
                     "made beside it)");
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
