// Whether a test that runs a finder can run it in this process: one decision
// for every test, taken from the finder table (gpu/pair_finder_table.cpp,
// PairFinderRow::needs_device), never from a finder's name.  A name the table
// lacks (Bullet's bf, sap, bvh) runs on the CPU.
//
// OVERLAP_NEEDS_DEVICE_FOR(name), in a test's body or SetUp(): where `name`
// needs a CUDA device and none can run it, the test skips and says why.  Under
// OVERLAP_REQUIRE_DEVICE=1 (ctest --preset gpu, on a GPU machine) it fails
// instead, so a missing or broken device cannot pass as skipped tests.  Any
// other value of OVERLAP_REQUIRE_DEVICE but unset, empty or 0 fails the test,
// naming the value.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <string_view>

#include "gpu/pair_finder.h"

namespace overlap::test_support {

inline bool needsDevice(std::string_view name) {
  for (const finders::PairFinderRow& row : finders::pairFinderTable()) {
    if (row.name == name) return row.needs_device;
  }
  return false;
}

enum class DeviceVerdict { kRun, kSkip, kFail };

// What a test of `name` does: `device_why` is empty where a device can run
// the GPU finders and says why not otherwise; `require` is
// OVERLAP_REQUIRE_DEVICE's value (null when unset).  `message` says why a
// test skips or fails.
inline DeviceVerdict deviceVerdict(std::string_view name, const std::string& device_why,
                                   const char* require, std::string* message) {
  const std::string_view required = require ? require : "";
  if (required != "" && required != "0" && required != "1") {
    *message = "OVERLAP_REQUIRE_DEVICE is '" + std::string(required) + "': it takes 1 or 0";
    return DeviceVerdict::kFail;
  }
  if (!needsDevice(name) || device_why.empty()) return DeviceVerdict::kRun;
  *message = std::string(name) + " needs a CUDA device: " + device_why;
  if (required != "1") return DeviceVerdict::kSkip;
  *message += " (OVERLAP_REQUIRE_DEVICE=1: a GPU test may not skip)";
  return DeviceVerdict::kFail;
}

// deviceVerdict() for this process: its device and its environment.
inline DeviceVerdict deviceVerdictHere(std::string_view name, std::string* message) {
  std::string why;
  if (needsDevice(name) && !finders::cudaDeviceAvailable(&why) && why.empty()) {
    why = "no reason given";
  }
  return deviceVerdict(name, why, std::getenv("OVERLAP_REQUIRE_DEVICE"), message);
}

}  // namespace overlap::test_support

#define OVERLAP_NEEDS_DEVICE_FOR(name)                                                     \
  do {                                                                                     \
    std::string overlap_device_message;                                                    \
    switch (::overlap::test_support::deviceVerdictHere((name), &overlap_device_message)) { \
      case ::overlap::test_support::DeviceVerdict::kRun:                                   \
        break;                                                                             \
      case ::overlap::test_support::DeviceVerdict::kSkip:                                  \
        GTEST_SKIP() << overlap_device_message;                                            \
      case ::overlap::test_support::DeviceVerdict::kFail:                                  \
        FAIL() << overlap_device_message;                                                  \
    }                                                                                      \
  } while (false)
