// What docs/CLI.md and docs/OUTPUTS.md say the program does, checked against
// the program: a line the docs quote is the line it prints, a list of the
// subcommands names every one, and the timeline's spans are on the lanes
// the docs put them on.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/engine/cli_test_support.h"

namespace {

using namespace overlap::testing;

std::string documentText(const std::string& name) {
  return fileText(std::filesystem::path(OVERLAP_SOURCE_DIR) / "docs" / name);
}

// The document's line holding `words`, its indentation dropped.
std::string lineWith(const std::string& document, const std::string& words) {
  std::istringstream in(document);
  for (std::string line; std::getline(in, line);) {
    if (line.find(words) != std::string::npos) return line.substr(line.find_first_not_of(' '));
  }
  return {};
}

// The subcommands as the program lists them for a word that names none.
std::vector<std::string> subcommands(const std::string& message) {
  const std::string after = "the subcommands are ";
  const std::size_t start = message.find(after) + after.size();
  std::vector<std::string> names;
  std::istringstream list(message.substr(start, message.find(" (see") - start));
  for (std::string name; std::getline(list, name, ',');) {
    names.push_back(name.substr(name.find_first_not_of(' ')));
  }
  return names;
}

TEST_F(CliTest, CliMdQuotesTheUnknownSubcommandLineAsTheProgramPrintsIt) {
  const Result result = runOverlap("bogus");
  ASSERT_EQ(result.exit_code, 2);
  const std::string printed = result.stderr_text.substr(0, result.stderr_text.find('\n'));
  EXPECT_EQ(lineWith(documentText("CLI.md"), "unknown subcommand 'bogus'"), printed);
}

TEST_F(CliTest, CliMdsOpeningNamesEverySubcommand) {
  const std::string opening = documentText("CLI.md").substr(0, 400);
  const std::vector<std::string> names = subcommands(runOverlap("bogus").stderr_text);
  ASSERT_GE(names.size(), 6u);
  for (const std::string& name : names) {
    EXPECT_NE(opening.find("`" + name + "`"), std::string::npos) << name << " in\n" << opening;
  }
}

// docs/OUTPUTS.md, "timeline.json": the frame, the step, each substep's
// spans and the wait for the tasks on the main lane; the tasks job and each
// task on lanes of their own; with the search beside the narrowphase, the
// broadphase on the search lane and the wait for it on the main lane.
void expectSpansOnLanes(const std::filesystem::path& timeline,
                        const std::map<std::string, std::string>& expected) {
  const nlohmann::json trace = nlohmann::json::parse(fileText(timeline));
  std::map<int, std::string> lanes;
  for (const nlohmann::json& event : trace["traceEvents"]) {
    if (event["ph"] == "M") lanes[event["tid"].get<int>()] = event["args"]["name"];
  }
  std::map<std::string, int> seen;
  for (const nlohmann::json& event : trace["traceEvents"]) {
    if (event["ph"] != "X") continue;
    const std::string name = event["name"];
    ++seen[name];
    ASSERT_TRUE(expected.contains(name)) << "a span OUTPUTS.md does not name: " << name;
    EXPECT_EQ(lanes[event["tid"].get<int>()], expected.at(name)) << name;
  }
  for (const auto& [name, lane] : expected) EXPECT_GT(seen[name], 0) << name;
}

TEST_F(CliTest, TimelineSpansAreOnTheLanesOutputsMdNames) {
  const Result result = runOverlap(
      "run --objects 40 --frames 3 --capture-every 0 --no-wav --narrowphase parallel --out " +
      out_.string());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  expectSpansOnLanes(out_ / "timeline.json", {{"frame", "main"},
                                              {"physics", "main"},
                                              {"substep", "main"},
                                              {"broadphase", "main"},
                                              {"narrowphase", "main"},
                                              {"wait for tasks", "main"},
                                              {"tasks", "tasks"},
                                              {"sound", "sound"},
                                              {"ai", "ai"}});
}

TEST_F(CliTest, TheSearchBesideTheNarrowphaseIsOnALaneOfItsOwn) {
  const Result result = runOverlap(
      "run --objects 40 --frames 3 --capture-every 0 --no-wav --algo cpusap --threads 2 --out " +
      out_.string());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  const nlohmann::json summary = nlohmann::json::parse(fileText(out_ / "summary.json"));
  if (summary["parameters"]["threads"].get<int>() < 2) GTEST_SKIP() << "one thread: nothing beside";
  expectSpansOnLanes(out_ / "timeline.json", {{"frame", "main"},
                                              {"physics", "main"},
                                              {"substep", "main"},
                                              {"broadphase", "search"},
                                              {"wait for search", "main"},
                                              {"narrowphase", "main"},
                                              {"wait for tasks", "main"},
                                              {"tasks", "tasks"},
                                              {"sound", "sound"},
                                              {"ai", "ai"}});
}

}  // namespace
