// The benchmark's stream cache: a cached stream is replayed only when its
// header says it was simulated as a fresh recording would be.
#include "engine/streams/recorded_streams.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>
#include <string>

#include "physics/aabb_stream.h"
#include "tests/scratch_path.h"

namespace overlap::engine {
namespace {

class StreamCache : public ::testing::Test {
 protected:
  void SetUp() override {
    std::filesystem::remove_all(folder_);
    std::filesystem::create_directories(folder_);
    config_.objects = 100;
  }
  void TearDown() override { std::filesystem::remove_all(folder_); }

  std::filesystem::path folder_ = overlap::testing::scratchPath("stream_cache");
  physics::SceneConfig config_ = physics::SceneConfig::forScene(1);
  static constexpr int kFrames = 3;
};

TEST_F(StreamCache, RecordsOnceThenReplaysTheSameStream) {
  const CachedStream first = loadOrRecordStream(folder_, config_, kFrames);
  EXPECT_TRUE(first.recorded);
  EXPECT_EQ(first.stream.scene_name, streamSceneName(config_, physics::WorldOptions{}));
  const CachedStream second = loadOrRecordStream(folder_, config_, kFrames);
  EXPECT_FALSE(second.recorded);
  EXPECT_EQ(second.stream.boxes.size(), first.stream.boxes.size());
}

TEST_F(StreamCache, AStreamSimulatedOtherwiseIsAnErrorNotAReplay) {
  physics::WorldOptions fixed_substeps;
  fixed_substeps.substeps = 8;  // the scenes' old default
  physics::writeAabbStream(cachedStreamPath(folder_, config_, kFrames),
                           recordStream(config_, kFrames, "test", fixed_substeps));
  try {
    loadOrRecordStream(folder_, config_, kFrames);
    FAIL() << "a stream recorded with 8 fixed substeps was replayed as the default's";
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("scene name"), std::string::npos) << message;
    EXPECT_NE(message.find("substeps 8"), std::string::npos) << message;
    EXPECT_NE(message.find("delete it"), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace overlap::engine
