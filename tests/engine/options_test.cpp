// The `overlap` options as a user reads them in --help: one --algo default
// everywhere (the rule that picks one), --quiet everywhere, a default shown for every option, one
// name per meaning, and an example in every subcommand's help.
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <string>

#include "engine/cli/app.h"
#include "engine/program/scene_options.h"

namespace overlap::engine {
namespace {

class OptionsTest : public ::testing::Test {
 protected:
  void SetUp() override { addCommands(app_); }
  CLI::App app_{"overlap", "overlap"};
};

// The default --help shows is the one that runs: the box-count rule
// (physics/broadphase/default_broadphase.h), in every subcommand that takes --algo.
TEST_F(OptionsTest, EverySubcommandShowsTheBoxCountRuleAsItsAlgorithmDefault) {
  int with_algo = 0;
  for (const CLI::App* command : app_.get_subcommands({})) {
    const CLI::Option* algo = command->get_option_no_throw("--algo");
    if (algo == nullptr) continue;
    ++with_algo;
    EXPECT_EQ(algo->get_default_str(), defaultAlgorithmRule()) << command->get_name();
    EXPECT_NE(command->help().find("=" + defaultAlgorithmRule()), std::string::npos)
        << command->get_name();
  }
  EXPECT_EQ(with_algo, 4);  // run, pairs, capture, latency
  EXPECT_EQ(defaultAlgorithmRule(),
            "the box-count rule: with a CUDA device cpubf below 500 boxes, gpubf below 13000, "
            "gpusap from there; without one cpusap");
}

// --quiet drops a run's summary in every subcommand.
TEST_F(OptionsTest, EverySubcommandTakesQuiet) {
  for (const CLI::App* command : app_.get_subcommands({})) {
    EXPECT_NE(command->get_option_no_throw("--quiet"), nullptr) << command->get_name();
  }
}

TEST_F(OptionsTest, EveryOptionShowsItsDefault) {
  for (const CLI::App* command : app_.get_subcommands({})) {
    for (const CLI::Option* option : command->get_options()) {
      if (option == command->get_help_ptr() || option->get_required()) continue;
      if (option->get_group().empty()) continue;  // hidden: a deprecated alias
      EXPECT_FALSE(option->get_default_str().empty())
          << command->get_name() << " " << option->get_name();
    }
  }
}

TEST_F(OptionsTest, EverySubcommandsHelpEndsWithAnExample) {
  for (const CLI::App* command : app_.get_subcommands({})) {
    EXPECT_NE(command->get_footer().find("overlap " + command->get_name() + " "), std::string::npos)
        << command->get_name() << ": " << command->get_footer();
  }
}

TEST_F(OptionsTest, FramesAreCountedInFrameTimesNotInThirtiethsOfASecond) {
  for (const CLI::App* command : app_.get_subcommands({})) {
    const CLI::Option* frames = command->get_option_no_throw("--frames");
    if (frames == nullptr) continue;
    EXPECT_EQ(frames->get_description().find("1/30"), std::string::npos) << command->get_name();
    EXPECT_NE(frames->get_description().find("--frame-time"), std::string::npos)
        << command->get_name();
  }
}

TEST_F(OptionsTest, ImageSizeHasOneNameInRunAndCapture) {
  for (const char* name : {"run", "capture"}) {
    const CLI::App* command = app_.get_subcommand(name);
    EXPECT_NE(command->get_option_no_throw("--capture-size"), nullptr) << name;
    const CLI::Option* size = command->get_option_no_throw("--size");
    EXPECT_TRUE(size == nullptr || size->get_group().empty()) << name << ": --size is visible";
  }
}

}  // namespace
}  // namespace overlap::engine
