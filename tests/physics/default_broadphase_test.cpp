// The default broadphase's rule (physics/broadphase/default_broadphase.h): cpubf, gpubf
// and gpusap by box count with a device, cpusap without, each exact, each
// with a one-line reason that names it and the box count.
#include "physics/broadphase/default_broadphase.h"

#include <gtest/gtest.h>

#include <string>

#include "physics/broadphase/broadphase_factory.h"

namespace overlap::physics {
namespace {

TEST(DefaultBroadphase, WithADevicePicksByBoxCountAtTheCrossovers) {
  EXPECT_EQ(defaultBroadphase(0, true).name, "cpubf");
  EXPECT_EQ(defaultBroadphase(kGpubfFrom - 1, true).name, "cpubf");
  EXPECT_EQ(defaultBroadphase(kGpubfFrom, true).name, "gpubf");
  EXPECT_EQ(defaultBroadphase(kGpusapFrom - 1, true).name, "gpubf");
  EXPECT_EQ(defaultBroadphase(kGpusapFrom, true).name, "gpusap");
  EXPECT_EQ(defaultBroadphase(1000000, true).name, "gpusap");
}

TEST(DefaultBroadphase, WithoutADeviceRunsTheFallbackAndSaysWhy) {
  for (const std::size_t objects :
       {std::size_t{10}, kGpubfFrom, kGpusapFrom, std::size_t{1} << 20}) {
    const DefaultBroadphase pick = defaultBroadphase(objects, false, "built without CUDA");
    EXPECT_EQ(pick.name, kDeviceFallback);
    EXPECT_NE(pick.reason.find("no CUDA device (built without CUDA)"), std::string::npos)
        << pick.reason;
  }
}

TEST(DefaultBroadphase, EveryPickIsExactAndItsReasonIsOneLineNamingIt) {
  for (const bool device : {false, true}) {
    for (const std::size_t objects : {std::size_t{1}, kGpubfFrom, kGpusapFrom}) {
      const DefaultBroadphase pick = defaultBroadphase(objects, device, "none");
      EXPECT_TRUE(broadphaseInfo(pick.name).exact) << pick.name;
      EXPECT_EQ(pick.reason.find('\n'), std::string::npos);
      EXPECT_NE(
          pick.reason.find(std::string(pick.name) + " for " + std::to_string(objects) + " boxes"),
          std::string::npos)
          << pick.reason;
    }
  }
}

}  // namespace
}  // namespace overlap::physics
