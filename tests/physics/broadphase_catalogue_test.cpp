// The broadphase catalogue (physics/broadphase/broadphase_factory.h) is the one list of
// broadphases: every name in it makes its broadphase, and README's table
// lists the same names with the same exactness.  Whether an "exact" entry
// really is exact is checked on the hard cases (tests/hard_cases/).
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>

#include "gpu/pair_finder.h"
#include "physics/broadphase/broadphase_factory.h"

namespace overlap::physics {
namespace {

// README's broadphases table, name -> exact: the rows after the header
// `| name | what | exact? |` and its `|---|` line, each
// `| \`NAME\` | description | yes... |` or `| \`NAME\` | description | no... |`.
// Throws std::runtime_error naming the first row it cannot read.
std::map<std::string, bool> readmeTable(const std::string& text) {
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line) && line != "| name | what | exact? |") {
  }
  if (!lines) throw std::runtime_error("no line `| name | what | exact? |`");
  std::getline(lines, line);  // |---|---|---|
  std::map<std::string, bool> table;
  while (std::getline(lines, line) && line.starts_with('|')) {
    const std::size_t name_start = line.find("| `");
    const std::size_t name_end = line.find("` |", name_start + 3);
    const std::size_t exact_start = line.rfind(" | ", line.size() - 2);
    if (name_start != 0 || name_end == std::string::npos || exact_start <= name_end ||
        !line.ends_with(" |")) {
      throw std::runtime_error("row not `| `NAME` | what | yes/no |`: " + line);
    }
    const std::string exact = line.substr(exact_start + 3);
    if (!exact.starts_with("yes") && !exact.starts_with("no")) {
      throw std::runtime_error("third column neither yes... nor no...: " + line);
    }
    const std::string name = line.substr(3, name_end - 3);
    if (!table.emplace(name, exact.starts_with("yes")).second) {
      throw std::runtime_error("row listed twice: " + line);
    }
  }
  return table;
}

TEST(BroadphaseCatalogue, ReadmeTableListsTheSameNamesAndExactness) {
  std::ifstream readme(OVERLAP_README);
  ASSERT_TRUE(readme) << "cannot read " << OVERLAP_README;
  std::stringstream text;
  text << readme.rdbuf();
  std::map<std::string, bool> catalogue;
  for (const BroadphaseInfo& info : broadphaseCatalogue()) {
    catalogue.emplace(std::string(info.name), info.exact);
  }
  EXPECT_EQ(readmeTable(text.str()), catalogue) << "README.md's broadphases table";
}

TEST(BroadphaseCatalogue, TheReadmeTableReaderRefusesWhatItCannotRead) {
  const std::string header = "| name | what | exact? |\n|---|---|---|\n";
  EXPECT_EQ(readmeTable(header + "| `bf` | brute | yes |\n| `sap` | sweep | no (quantized) |\n"),
            (std::map<std::string, bool>{{"bf", true}, {"sap", false}}));
  EXPECT_THROW(readmeTable(header + "| `sap` | sweep | conservative |\n"), std::runtime_error);
  EXPECT_THROW(readmeTable(header + "| sap | sweep | no |\n"), std::runtime_error);
  EXPECT_THROW(readmeTable(header + "| `bf` | a | yes |\n| `bf` | b | yes |\n"),
               std::runtime_error);
  EXPECT_THROW(readmeTable("| name | what |\n"), std::runtime_error);
}

TEST(BroadphaseCatalogue, EveryNameMakesItsBroadphaseOrSaysWhyNot) {
  std::set<std::string_view> names;
  std::string why;
  const bool have_device = finders::cudaDeviceAvailable(&why);
  for (const BroadphaseInfo& info : broadphaseCatalogue()) {
    EXPECT_TRUE(names.insert(info.name).second) << info.name << " listed twice";
    EXPECT_FALSE(info.description.empty()) << info.name;
    EXPECT_EQ(&broadphaseInfo(info.name), &info);
    const BroadphaseChoice choice =
        makeBroadphase(info.name, btVector3(-10, -10, -10), btVector3(10, 10, 10), 64);
    ASSERT_NE(choice.broadphase, nullptr) << info.name;
    if (info.needs_device && !have_device) {
      EXPECT_EQ(choice.name, kDeviceFallback) << info.name;
      EXPECT_NE(choice.notice.find(why), std::string::npos) << choice.notice;
    } else {
      EXPECT_EQ(choice.name, info.name);
      EXPECT_EQ(choice.notice, "");
    }
  }
  EXPECT_TRUE(broadphaseInfo(kDeviceFallback).exact);
  EXPECT_FALSE(broadphaseInfo(kDeviceFallback).needs_device);
  EXPECT_THROW(broadphaseInfo("octree"), std::invalid_argument);
  EXPECT_THROW(makeBroadphase("octree", btVector3(-1, -1, -1), btVector3(1, 1, 1), 4),
               std::invalid_argument);
}

}  // namespace
}  // namespace overlap::physics
