// libFuzzer target: the `overlap` command line.  The input is split into
// arguments at NULs and whitespace and parsed by the app main() runs
// (engine/cli/app.h), every check and validator included, but no subcommand
// runs and nothing is written; then the checks each subcommand makes before
// it starts run on what was parsed.
// Rejections are CLI::ParseError (help included), engine::UsageError or
// std::invalid_argument; any other exception escapes and is a finding.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <iterator>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "audio_ai_stubs/ai.h"
#include "audio_ai_stubs/sound.h"
#include "engine/cli/app.h"
#include "engine/program/scene_options.h"
#include "engine/program/usage_error.h"
#include "render/capture_options.h"

namespace {

std::vector<std::string> splitArguments(const std::uint8_t* data, std::size_t size) {
  std::vector<std::string> arguments{"overlap"};
  std::string current;
  for (std::size_t i = 0; i < size; ++i) {
    const char c = static_cast<char>(data[i]);
    if (c == '\0' || c == ' ' || c == '\t' || c == '\n' || c == '\r') {
      if (!current.empty()) arguments.push_back(std::move(current));
      current.clear();
    } else {
      current += c;
    }
  }
  if (!current.empty()) arguments.push_back(std::move(current));
  return arguments;
}

void parse(CLI::App& app, std::vector<std::string>& arguments) {
  std::vector<char*> argv;
  for (std::string& argument : arguments) argv.push_back(argument.data());
  app.parse(static_cast<int>(argv.size()), argv.data());
}

// The checks the subcommands make after parsing, before they start: the
// scene options resolved into a SceneConfig (run, record, capture, latency),
// the sound and AI task settings (run), the image size (run, capture); the
// lists (--keyframes, --growth, ...) are checked while parsing.  They read options the commands
// keep to themselves, so a second app declares just those (the rest pass as extras); the render
// parsers' errors become UsageErrors, as in the commands.
struct StartChecks {
  overlap::engine::SceneOptions scene;
  overlap::stubs::SoundConfig sound;
  overlap::stubs::AiConfig ai;
  std::string image_size = "800x600";
};

void checkAsTheCommandsDo(std::vector<std::string>& arguments) {
  CLI::App app{"start checks", "overlap"};
  app.require_subcommand(1);
  const std::string names[] = {"run", "record", "capture", "latency"};
  std::vector<StartChecks> checks(std::size(names));
  std::vector<CLI::App*> commands;
  for (std::size_t i = 0; i < checks.size(); ++i) {
    CLI::App* command = app.add_subcommand(names[i]);
    command->allow_extras();
    checks[i].scene.addTo(*command);
    if (names[i] == "run") {
      command->add_option("--voices", checks[i].sound.voices);
      command->add_option("--background-voices", checks[i].sound.background_voices);
      command->add_option("--agents", checks[i].ai.agents);
      command->add_option("--capture-size", checks[i].image_size);
    }
    if (names[i] == "capture") {
      command->add_option("--capture-size,--size", checks[i].image_size);
    }
    commands.push_back(command);
  }
  parse(app, arguments);
  for (std::size_t i = 0; i < checks.size(); ++i) {
    if (!commands[i]->parsed()) continue;
    checks[i].scene.resolve();
    checks[i].sound.validate();
    checks[i].ai.validate();
    try {
      overlap::render::parseImageSize(checks[i].image_size);
    } catch (const std::runtime_error& error) {
      throw overlap::engine::UsageError(error.what());
    }
  }
}

// Thrown once parsing is complete, to stop before the subcommand runs.
struct ParsedWithoutRunning {};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::string> arguments = splitArguments(data, size);
  try {
    CLI::App app{"overlap", "overlap"};
    overlap::engine::addCommands(app);
    // Each command's options live in its callback, so replacing the callbacks
    // would free them under the parser.  CLI11 runs the top-level app's
    // parse-complete callback after every check and before any subcommand's
    // callback: stopping there parses everything and runs nothing.
    app.parse_complete_callback([] { throw ParsedWithoutRunning{}; });
    try {
      parse(app, arguments);
    } catch (const ParsedWithoutRunning&) {
      checkAsTheCommandsDo(arguments);
    }
  } catch (const CLI::ParseError&) {
  } catch (const overlap::engine::UsageError&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
