// The one decision of tests/needs_device.h: which finders need a device (the
// finder table's), and what a test of one does with and without a device,
// under each value of OVERLAP_REQUIRE_DEVICE.
#include "tests/needs_device.h"

#include <gtest/gtest.h>

#include <string>

#include "gpu/pair_finder.h"

namespace overlap::test_support {
namespace {

TEST(NeedsDevice, IsTheFinderTablesAnswerForEveryRow) {
  for (const finders::PairFinderRow& row : finders::pairFinderTable()) {
    EXPECT_EQ(needsDevice(row.name), row.needs_device) << row.name;
  }
}

TEST(NeedsDevice, ANameTheTableLacksRunsOnTheCpu) {
  for (const char* name : {"bf", "sap", "sap32", "bvh", "nonsense"}) {
    EXPECT_FALSE(needsDevice(name)) << name;
  }
}

TEST(DeviceVerdict, ACpuFinderRunsWithoutADeviceWhateverIsRequired) {
  std::string message;
  for (const char* require : {static_cast<const char*>(nullptr), "", "0", "1"}) {
    EXPECT_EQ(deviceVerdict("cpubf", "no CUDA device", require, &message), DeviceVerdict::kRun);
    EXPECT_EQ(deviceVerdict("bvh", "no CUDA device", require, &message), DeviceVerdict::kRun);
  }
}

TEST(DeviceVerdict, AGpuFinderSkipsWithoutADeviceAndSaysWhy) {
  for (const char* require : {static_cast<const char*>(nullptr), "", "0"}) {
    std::string message;
    EXPECT_EQ(deviceVerdict("gpubf", "the driver is too old", require, &message),
              DeviceVerdict::kSkip);
    EXPECT_EQ(message, "gpubf needs a CUDA device: the driver is too old");
  }
}

TEST(DeviceVerdict, AGpuFinderFailsWithoutADeviceUnderRequireDevice) {
  std::string message;
  EXPECT_EQ(deviceVerdict("gpusap", "no CUDA device", "1", &message), DeviceVerdict::kFail);
  EXPECT_NE(message.find("gpusap needs a CUDA device: no CUDA device"), std::string::npos)
      << message;
  EXPECT_NE(message.find("OVERLAP_REQUIRE_DEVICE=1"), std::string::npos) << message;
}

TEST(DeviceVerdict, AGpuFinderRunsWithADevice) {
  std::string message;
  for (const char* require : {static_cast<const char*>(nullptr), "0", "1"}) {
    EXPECT_EQ(deviceVerdict("gpubf-paper", "", require, &message), DeviceVerdict::kRun);
  }
}

TEST(DeviceVerdict, AnotherRequireDeviceValueFailsNamingIt) {
  std::string message;
  EXPECT_EQ(deviceVerdict("cpubf", "", "yes", &message), DeviceVerdict::kFail);
  EXPECT_EQ(message, "OVERLAP_REQUIRE_DEVICE is 'yes': it takes 1 or 0");
}

}  // namespace
}  // namespace overlap::test_support
