// The lean frames of gpubf and gpusap, counted by the CUDA emulation: one
// upload, one copy back, one host wait (gpubf: one kernel, no memset); and
// the copies' bytes.
#include "tests/gpu/frame_cost.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "gpu/pair_finder.h"

namespace overlap::finders {
namespace {

// Both lean finders' steady frame: one upload, one copy back, one host wait,
// whatever n.  gpubf: one kernel and no memset.  gpusap: its four kernels
// and no memset (its first kernel fills the unused slots, its last zeroes
// the counters); its CUB calls run over capacities, so nothing comes back
// mid-frame.
TEST(LeanFrameCostTest, OneUploadOneCopyBackAndOneWaitAFrame) {
  struct Expected {
    std::string_view finder;
    std::uint64_t kernels;
    std::uint64_t memsets;
  };
  for (const Expected expected : {Expected{"gpubf", 1, 0}, Expected{"gpusap", 4, 0}}) {
    for (const std::uint32_t n : {2u, 33u, 1025u}) {
      const auto finder = makePairFinder(expected.finder);
      SCOPED_TRACE(std::string(finder->name()) + ", n = " + std::to_string(n));
      const cuda_emulation::ApiCounters frame = testing::steadyFrameCost(*finder, n);
      EXPECT_EQ(frame.kernel_launches, expected.kernels);
      EXPECT_EQ(frame.copies_to_device, 1u);
      EXPECT_EQ(frame.copies_to_host, 1u) << "every change fits the head";
      EXPECT_EQ(frame.copies_on_device, 0u);
      EXPECT_EQ(frame.memsets, expected.memsets);
      EXPECT_EQ(frame.bytes_to_device, n * sizeof(ObjectBounds));
      EXPECT_EQ(frame.host_waits, 1u);
    }
  }
}

TEST(GpubfFrameCostTest, TheCallerFillsTheStagingItself) {
  const auto finder = makePairFinder("gpubf");
  const std::span<ObjectBounds> staging = finder->stagingFor(40);
  ASSERT_EQ(staging.size(), 40u);
  const std::vector<ObjectBounds> boxes = testing::steppingBoxes(40, 0);
  std::copy(boxes.begin(), boxes.end(), staging.begin());
  finder->launch(staging);
  const PairDelta delta = finder->finish();
  EXPECT_EQ(delta.added.size(), 19u);  // (1, 2), (3, 4) ... (37, 38)
  EXPECT_THROW(
      {
        finder->launch(staging);
        finder->stagingFor(40);
      },
      std::runtime_error);
  finder->finish();
}

TEST(GpubfPaperFrameCostTest, CopiesEveryPairsByteBack) {
  const auto finder = makePairFinder("gpubf-paper");
  const cuda_emulation::ApiCounters frame = testing::steadyFrameCost(*finder, 1025);
  EXPECT_EQ(frame.kernel_launches, 1u);
  EXPECT_EQ(frame.bytes_to_host, 1025u * 1024u / 2u);
}

}  // namespace
}  // namespace overlap::finders
