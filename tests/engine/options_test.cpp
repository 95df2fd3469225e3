// The `overlap` options as a user reads them in --help: one --algo default
// everywhere, a default shown for every option, one name per meaning, and an
// example in every subcommand's help.
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <string>

#include "engine/cli/app.h"
#include "engine/cli/scene_options.h"

namespace overlap::engine {
namespace {

class OptionsTest : public ::testing::Test {
 protected:
  void SetUp() override { addCommands(app_); }
  CLI::App app_{"overlap", "overlap"};
};

TEST_F(OptionsTest, EverySubcommandDefaultsToTheSameAlgorithm) {
  int with_algo = 0;
  for (const CLI::App* command : app_.get_subcommands({})) {
    const CLI::Option* algo = command->get_option_no_throw("--algo");
    if (algo == nullptr) continue;
    ++with_algo;
    std::string shown = algo->get_default_str();
    // A list option (latency's) shows its default as "[gpubf]".
    if (shown.size() > 2 && shown.front() == '[') shown = shown.substr(1, shown.size() - 2);
    EXPECT_EQ(shown, kDefaultAlgorithm) << command->get_name();
  }
  EXPECT_EQ(with_algo, 4);  // run, pairs, capture, latency
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
