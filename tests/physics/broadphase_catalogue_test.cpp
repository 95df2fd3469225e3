// The broadphase catalogue (physics/broadphase/broadphase_factory.h) is the one list of
// broadphases: every name in it makes its broadphase, and README's table
// lists the same names with the same exactness.  Whether an "exact" entry
// really is exact is checked on the hard cases (tests/hard_cases/).
#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <csignal>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gpu/base/interrupt.h"
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

// `boxes` unit boxes added, in a row, to a stock Bullet world on the
// broadphase `name` makes for `max_objects` (what a package user writes).
void addBoxes(std::string_view name, int max_objects, int boxes) {
  BroadphaseChoice choice =
      makeWorldBroadphase(name, btVector3(-100, -100, -100), btVector3(100, 100, 100), max_objects);
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, choice.broadphase.get(), &solver, &config);
  btBoxShape shape(btVector3(0.5f, 0.5f, 0.5f));
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  struct Remove {
    btDiscreteDynamicsWorld& world;
    std::vector<std::unique_ptr<btRigidBody>>& bodies;
    ~Remove() {
      for (auto& body : bodies) {
        if (body->getBroadphaseHandle() != nullptr) world.removeRigidBody(body.get());
      }
    }
  } remove{world, bodies};
  for (int i = 0; i < boxes; ++i) {
    bodies.push_back(std::make_unique<btRigidBody>(1.0f, nullptr, &shape, btVector3(1, 1, 1)));
    bodies.back()->setWorldTransform(
        btTransform(btQuaternion::getIdentity(), btVector3(0.9f * static_cast<float>(i), 0, 0)));
    world.addRigidBody(bodies.back().get());
  }
  world.stepSimulation(1.0f / 60.0f, 0);
}

TEST(BroadphaseCatalogue, BulletsFixedBroadphasesRefuseAProxyPastMaxObjectsNamingIt) {
  for (const std::string_view name : {"bf", "sap", "sap32"}) {
    for (const int max_objects : {0, 5}) {
      try {
        addBoxes(name, max_objects, 50);
        ADD_FAILURE() << name << " with max_objects " << max_objects << " took 50 boxes";
      } catch (const std::invalid_argument& error) {
        const std::string text = error.what();
        EXPECT_NE(text.find("max_objects " + std::to_string(max_objects)), std::string::npos)
            << text;
        EXPECT_NE(text.find("algo " + std::string(name) + ":"), std::string::npos) << text;
      }
    }
    EXPECT_NO_THROW(addBoxes(name, 50, 50)) << name << " holds as many as it was made for";
  }
}

TEST(BroadphaseCatalogue, TheGrowingBroadphasesTakeMoreThanMaxObjects) {
  for (const std::string_view name : {"bvh", "cpusap", "cpubf"}) {
    EXPECT_NO_THROW(addBoxes(name, 5, 50)) << name;
  }
}

TEST(BroadphaseCatalogue, WorldBoundsThatAreNotFiniteOrAreInvertedAreRefused) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (const BroadphaseInfo& info : broadphaseCatalogue()) {
    for (const auto& [low, high] : {std::pair{btVector3(-1, nan, -1), btVector3(1, 1, 1)},
                                    std::pair{btVector3(-1, -1, -1), btVector3(1, 1, inf)},
                                    std::pair{btVector3(-inf, -1, -1), btVector3(1, 1, 1)},
                                    std::pair{btVector3(1, -1, -1), btVector3(-1, 1, 1)}}) {
      EXPECT_THROW(makeWorldBroadphase(info.name, low, high, 10), std::invalid_argument)
          << info.name;
    }
  }
}

TEST(BroadphaseCatalogue, ANegativeMaxObjectsIsRefusedNamingIt) {
  for (const BroadphaseInfo& info : broadphaseCatalogue()) {
    try {
      makeBroadphase(info.name, btVector3(-1, -1, -1), btVector3(1, 1, 1), -1);
      ADD_FAILURE() << info.name << " took max_objects -1";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find("max_objects -1"), std::string::npos)
          << error.what();
    }
  }
}

// bf's pass over every pair looks at the signal flag as it goes: a frame of
// many boxes stops early, and a later pass finds every pair.
TEST(BroadphaseCatalogue, BfsPairPassStopsForASignalAndFindsEveryPairAfter) {
  constexpr int kBoxes = 2000;
  BroadphaseChoice bf =
      makeBroadphase("bf", btVector3(-10, -10, -10), btVector3(3000, 10, 10), kBoxes);
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  std::vector<btBroadphaseProxy*> proxies;
  int owner = 0;  // bf skips a proxy with no client object
  for (int i = 0; i < kBoxes; ++i) {
    const btVector3 centre(0.9f * static_cast<float>(i), 0, 0);
    proxies.push_back(bf.broadphase->createProxy(centre - btVector3(0.5f, 0.5f, 0.5f),
                                                 centre + btVector3(0.5f, 0.5f, 0.5f),
                                                 BOX_SHAPE_PROXYTYPE, &owner, 1, -1, &dispatcher));
  }
  interrupt_detail::received = SIGINT;
  bf.broadphase->calculateOverlappingPairs(&dispatcher);
  interrupt_detail::received = 0;
  const int cut_short = bf.broadphase->getOverlappingPairCache()->getNumOverlappingPairs();
  EXPECT_LT(cut_short, kBoxes - 1) << "the pass ran to its end with a signal pending";
  bf.broadphase->calculateOverlappingPairs(&dispatcher);
  EXPECT_EQ(bf.broadphase->getOverlappingPairCache()->getNumOverlappingPairs(), kBoxes - 1);
  for (btBroadphaseProxy* proxy : proxies) bf.broadphase->destroyProxy(proxy, &dispatcher);
}

}  // namespace
}  // namespace overlap::physics
