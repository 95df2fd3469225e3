// `overlap --list-algos [--json]` prints the broadphase catalogue, and only it.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "engine/cli/algorithm_list.h"
#include "physics/broadphase/broadphase_factory.h"

namespace overlap::engine {
namespace {

struct Output {
  int exit_code;
  std::string stdout_text;
};

Output runOverlap(const std::string& args) {
  const std::string command = std::string(OVERLAP_BINARY) + " " + args + " 2>/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return {-1, ""};
  std::string text;
  std::array<char, 4096> buffer;
  while (const std::size_t got = std::fread(buffer.data(), 1, buffer.size(), pipe)) {
    text.append(buffer.data(), got);
  }
  return {WEXITSTATUS(pclose(pipe)), text};
}

TEST(ListAlgos, JsonListsTheCatalogueInItsOrder) {
  const Output output = runOverlap("--list-algos --json");
  ASSERT_EQ(output.exit_code, 0);
  const nlohmann::json json = nlohmann::json::parse(output.stdout_text);
  EXPECT_EQ(json, algorithmListJson());
  std::vector<std::string> names;
  for (const nlohmann::json& entry : json.at("broadphases")) {
    const physics::BroadphaseInfo& info =
        physics::broadphaseInfo(entry.at("name").get<std::string>());
    EXPECT_EQ(entry.at("exact").get<bool>(), info.exact);
    EXPECT_EQ(entry.at("needs_device").get<bool>(), info.needs_device);
    EXPECT_EQ(entry.at("description").get<std::string>(), info.description);
    names.push_back(entry.at("name").get<std::string>());
  }
  EXPECT_EQ(names, std::vector<std::string>(physics::broadphaseNames().begin(),
                                            physics::broadphaseNames().end()));
  EXPECT_EQ(json.at("device_fallback").get<std::string>(), physics::kDeviceFallback);
}

TEST(ListAlgos, TextHasAHeaderALinePerBroadphaseAndTheFallback) {
  const Output output = runOverlap("--list-algos");
  ASSERT_EQ(output.exit_code, 0);
  EXPECT_EQ(output.stdout_text, algorithmListText());
  std::vector<std::string> lines;
  std::size_t start = 0;
  for (std::size_t end; (end = output.stdout_text.find('\n', start)) != std::string::npos;
       start = end + 1) {
    lines.push_back(output.stdout_text.substr(start, end - start));
  }
  const auto catalogue = physics::broadphaseCatalogue();
  ASSERT_EQ(lines.size(), catalogue.size() + 2);
  EXPECT_TRUE(lines.front().starts_with("name")) << lines.front();
  for (std::size_t i = 0; i < catalogue.size(); ++i) {
    EXPECT_TRUE(lines[i + 1].starts_with(std::string(catalogue[i].name) + ' ')) << lines[i + 1];
    EXPECT_NE(lines[i + 1].find(catalogue[i].description), std::string::npos) << lines[i + 1];
  }
  EXPECT_NE(lines.back().find("gpubf, gpubf-paper and gpusap run cpusap"), std::string::npos)
      << lines.back();
}

TEST(ListAlgos, JsonAloneIsAUsageError) {
  EXPECT_EQ(runOverlap("--json").exit_code, 2);
}

}  // namespace
}  // namespace overlap::engine
