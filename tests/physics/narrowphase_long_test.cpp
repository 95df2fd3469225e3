// The narrowphase test at the size: a 3500-box scene-4 run, every
// frame's contacts equal to Bullet's serial dispatch's, with the search
// beside the narrowphase and without it, for every finder (the GPU ones on
// a device or in the CUDA emulation build).  Label long.
#include <gtest/gtest.h>

#include <string>

#include "gpu/pair_finder.h"
#include "tests/physics/narrowphase_support.h"

namespace overlap::physics {
namespace {

using testing::firstDifferentFrame;
using testing::runContacts;

class NarrowphaseLong : public ::testing::TestWithParam<std::string_view> {};

TEST_P(NarrowphaseLong, ContactsOfA3500BoxPileEqualTheSerialDispatchsEveryFrame) {
  const std::string algorithm(GetParam());
  const auto one = makeTaskSystem(1);
  const auto two = makeTaskSystem(2, TaskBackEnd::kPlainThreads);
  const testing::ContactRun serial =
      runContacts(algorithm, NarrowphaseMode::kBullet, *one, 4, 3500, 12);
  for (const NarrowphaseMode mode : {NarrowphaseMode::kParallel, NarrowphaseMode::kBesideSearch}) {
    const testing::ContactRun run = runContacts(algorithm, mode, *two, 4, 3500, 12);
    EXPECT_EQ(firstDifferentFrame(serial, run), -1)
        << serial.algorithm << ", " << narrowphaseModeName(mode);
    EXPECT_EQ(run.state, serial.state);
  }
}

std::vector<std::string_view> finderNames() {
  std::vector<std::string_view> names;
  for (const finders::PairFinderRow& row : finders::pairFinderTable()) names.push_back(row.name);
  return names;
}

INSTANTIATE_TEST_SUITE_P(EveryFinder, NarrowphaseLong, ::testing::ValuesIn(finderNames()),
                         [](const ::testing::TestParamInfo<std::string_view>& info) {
                           std::string name(info.param);
                           for (char& c : name) {
                             if (c == '-') c = '_';
                           }
                           return name;
                         });

}  // namespace
}  // namespace overlap::physics
