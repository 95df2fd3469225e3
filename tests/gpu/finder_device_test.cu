// The GPU finders' device frame (gpu/cuda/finder_device.h) and the owning
// handles it is made of (gpu/cuda/cuda_handles.h): a creation that fails
// part way through leaves no stream, event or graph behind, and a finder
// whose frame fails to build its graph leaks nothing either.  Emulation
// build only: the emulation counts the live handles and fails the creation
// a test asks it to.
#include <cuda_runtime.h>
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "gpu/cuda/cuda_handles.h"
#include "gpu/cuda/finder_device.h"
#include "gpu/emulation/api_counters.h"
#include "gpu/pair_finder.h"
#include "tests/gpu/frame_cost.h"

namespace overlap::finders {
namespace {

using cuda_emulation::failHandleCreation;
using cuda_emulation::LiveHandles;
using cuda_emulation::liveHandles;

// No injected failure outlives a test, whether or not it fired.
class FinderDeviceTest : public ::testing::Test {
 protected:
  void TearDown() override { failHandleCreation(0); }
};

TEST_F(FinderDeviceTest, AFrameHoldsTenEventsAndItsStreamAndReleasesThemAll) {
  const LiveHandles before = liveHandles();
  {
    const FinderDevice frame;
    const LiveHandles held = liveHandles();
    EXPECT_EQ(held.streams, before.streams + 1);
    EXPECT_EQ(held.events, before.events + 2 * FinderDevice::kStageCount);
  }
  EXPECT_EQ(liveHandles(), before);
  {
    const FinderDevice frame(FinderDevice::StreamKind::kLegacyDefault);
    EXPECT_EQ(liveHandles().streams, before.streams);
    EXPECT_EQ(frame.stream(), nullptr);
  }
  EXPECT_EQ(liveHandles(), before);
}

TEST_F(FinderDeviceTest, AFailedCreationAtAnyPointOfTheConstructorLeaksNothing) {
  const LiveHandles before = liveHandles();
  const int creations = 2 * FinderDevice::kStageCount + 1;  // the events, then the stream
  for (int nth = 1; nth <= creations; ++nth) {
    SCOPED_TRACE("creation " + std::to_string(nth) + " fails");
    failHandleCreation(nth);
    EXPECT_THROW(FinderDevice{}, std::runtime_error);
    EXPECT_EQ(liveHandles(), before);
  }
  failHandleCreation(creations + 1);  // one past the constructor's: it succeeds
  { const FinderDevice frame; }
  EXPECT_EQ(liveHandles(), before);
}

TEST_F(FinderDeviceTest, AHandleMovedFromReleasesNothingAndItsNewOwnerReleasesOnce) {
  const LiveHandles before = liveHandles();
  Event first = makeEvent();
  Event second = std::move(first);
  EXPECT_FALSE(first);
  EXPECT_TRUE(second);
  EXPECT_EQ(liveHandles().events, before.events + 1);
  second = makeEvent();  // releases the first event
  EXPECT_EQ(liveHandles().events, before.events + 1);
  second.reset();
  EXPECT_EQ(liveHandles(), before);
}

TEST_F(FinderDeviceTest, AGpubfFrameWhoseGraphFailsToInstantiateThrowsAndLeaksNothing) {
  const LiveHandles before = liveHandles();
  {
    const auto finder = makePairFinder("gpubf");
    failHandleCreation(1);  // the first frame's graph executable
    const auto boxes = testing::steppingBoxes(64, 0);
    EXPECT_THROW(
        {
          finder->launch(boxes);
          finder->finish();
        },
        std::runtime_error);
    // The next frame captures its graph anew and finds the pairs.
    finder->launch(boxes);
    EXPECT_FALSE(finder->finish().added.empty());
  }
  EXPECT_EQ(liveHandles(), before);
}

}  // namespace
}  // namespace overlap::finders
