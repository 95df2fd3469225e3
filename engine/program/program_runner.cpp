#include "engine/program/program_runner.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <new>
#include <string>
#include <string_view>

#include "engine/program/usage_error.h"
#include "gpu/base/interrupt.h"
#include "gpu/base/shown_value.h"
#include "gpu/base/standard_streams.h"

namespace overlap::engine {
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

namespace {

// CLI11's list of the words nobody took ("The following arguments were not
// expected: a b"), each word as shownValue shows it and the first few only:
// the words are the user's, of any length and number.
std::string extrasText(const std::string& text) {
  constexpr std::string_view kListStart = "expected: ";
  constexpr int kMostListed = 4;
  const std::size_t start = text.find(kListStart);
  if (start == std::string::npos) return text;
  std::string shown = text.substr(0, start + kListStart.size());
  std::string_view rest = std::string_view(text).substr(start + kListStart.size());
  int listed = 0;
  int left = 0;
  while (!rest.empty()) {
    const std::size_t space = rest.find(' ');
    const std::string_view word = rest.substr(0, space);
    if (listed < kMostListed) {
      shown += (listed == 0 ? "" : " ") + shownValue(word);
      ++listed;
    } else {
      ++left;
    }
    rest = space == std::string_view::npos ? std::string_view() : rest.substr(space + 1);
  }
  return left == 0 ? shown : shown + " and " + std::to_string(left) + " more";
}

// CLI11's words for a parse error, in the project's where they are its
// own jargon: "--objects: At Most 1 required but received 2".
// (Read by hand: std::regex matches recursively, and a 50,000-character
// argument in the text overflowed the stack.)
std::string parseErrorText(const CLI::ParseError& error) {
  constexpr std::string_view kRepeated = ": At Most 1 required but received ";
  const std::string text = error.what();
  if (dynamic_cast<const CLI::ExtrasError*>(&error) != nullptr) return extrasText(text);
  const std::size_t mark = text.rfind(kRepeated);
  if (mark == std::string::npos) return text;
  const std::string count = text.substr(mark + kRepeated.size());
  const bool digits = !count.empty() && std::all_of(count.begin(), count.end(),
                                                    [](char c) { return c >= '0' && c <= '9'; });
  return digits ? text.substr(0, mark) + " is given " + count + " times; give it once" : text;
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

namespace {

// Writes `text` to stderr without allocating.
void writeToStderr(const char* text) {
  writeMessage(text, std::strlen(text));
}

}  // namespace

int startProgram(const char* program, const std::function<int()>& program_main) noexcept {
  try {
    return program_main();
  } catch (const std::bad_alloc&) {
    writeToStderr(program);
    writeToStderr(": out of memory while starting (ulimit -v or the machine's memory)\n");
  } catch (...) {
    writeToStderr(program);
    writeToStderr(": error: the command line could not be built\n");
  }
  return 1;
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
  // A signal after the last moment one could stop the run (its outputs'
  // publication) stopped nothing: the run ended as if it had not come.
  if (const int signal_number = pendingInterrupt(); code == 0 && signal_number != 0) {
    printError(program, std::string(signalName(signal_number)) +
                            " came after the outputs were published: they hold this run");
  }
  const int flushed = flushStandardOutput(program);
  return code == 0 ? flushed : code;
}

}  // namespace overlap::engine
