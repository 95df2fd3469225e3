#include "audio_ai_stubs/ai.h"

#include <gtest/gtest.h>
#include <oneapi/tbb/task_group.h>

#include <algorithm>
#include <limits>
#include <vector>

#include "audio_ai_stubs/sound.h"
#include "gpu/base/checksum.h"
#include "gpu/base/random.h"

namespace overlap::stubs {
namespace {

constexpr float kHalfExtent = 8.0f;

std::vector<Obstacle> randomBoxes(std::uint64_t seed, int count) {
  SeededRandom random(seed);
  std::vector<Obstacle> boxes(static_cast<std::size_t>(count));
  for (Obstacle& box : boxes) {
    for (int axis = 0; axis < 3; ++axis) {
      box.centre[axis] = static_cast<float>(random.uniform(-kHalfExtent, kHalfExtent));
    }
    box.radius = static_cast<float>(random.uniform(0.2, 1.5));
  }
  return boxes;
}

// Boxes that drift a little each frame, as last frame's positions would.
void drift(std::vector<Obstacle>& boxes, int frame) {
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    boxes[i].centre.x() +=
        0.02f * static_cast<float>(((i + static_cast<std::size_t>(frame)) % 5)) - 0.04f;
  }
}

AiConfig smallCrowd(int agents) {
  AiConfig config;
  config.agents = agents;
  return config;
}

TEST(AgentCrowd, AgentsStayInsideTheContainer) {
  AiConfig config = smallCrowd(64);
  config.wall_margin = 0.0f;  // no steering away from walls: only the clamp holds them
  AgentCrowd crowd(config, kHalfExtent);
  // Some agents are sent at targets beyond the walls, along every axis.
  for (std::size_t i = 0; i < 12; ++i) {
    Eigen::Vector3f beyond = Eigen::Vector3f::Zero();
    beyond[static_cast<int>(i % 3)] = (i % 2 == 0 ? 3.0f : -3.0f) * kHalfExtent;
    crowd.placeAgent(i, Eigen::Vector3f::Zero(), beyond);
  }
  std::vector<Obstacle> boxes = randomBoxes(5, 60);
  const float limit = kHalfExtent - config.agent_radius;
  for (int frame = 0; frame < 300; ++frame) {
    drift(boxes, frame);
    crowd.runFrame(boxes);
    for (const Eigen::Vector3f& position : crowd.positions()) {
      ASSERT_TRUE((position.array().abs() <= limit).all())
          << "frame " << frame << ": agent at " << position.transpose();
    }
  }
  EXPECT_GT(crowd.work().agent_box_tests, 0u);
  EXPECT_GT(crowd.work().agent_agent_tests, 0u);
  EXPECT_GT(crowd.work().targets_reached, 0u);
}

// One agent flies at a box that sits on the straight line to its target,
// dead centre or slightly off it; steering alone must take it around.
class BoxOnThePath : public ::testing::TestWithParam<float> {};

TEST_P(BoxOnThePath, SteeringKeepsTheAgentClearAndItArrives) {
  const AiConfig config = smallCrowd(1);
  AgentCrowd crowd(config, 12.0f);
  const Obstacle box{Eigen::Vector3f(0.0f, GetParam(), 0.0f), 1.5f};
  crowd.placeAgent(0, Eigen::Vector3f(-8.0f, 0.0f, 0.0f), Eigen::Vector3f(8.0f, 0.0f, 0.0f));
  float closest = std::numeric_limits<float>::infinity();
  int frame = 0;
  for (; frame < 300 && crowd.work().targets_reached == 0; ++frame) {
    crowd.runFrame({&box, 1});
    closest = std::min(closest, (crowd.positions()[0] - box.centre).norm());
  }
  EXPECT_EQ(crowd.work().targets_reached, 1u) << "did not arrive in " << frame << " frames";
  EXPECT_GE(closest, box.radius + config.agent_radius);
  EXPECT_EQ(crowd.work().penetrations_resolved, 0u) << "the fallback push-out had to act";
}

INSTANTIATE_TEST_SUITE_P(Offsets, BoxOnThePath, ::testing::Values(0.0f, 0.3f, -1.0f));

TEST(AgentCrowd, NeighboursFlyingSideBySideSeparate) {
  auto gapAfterFlight = [](float separation_distance) {
    AiConfig config = smallCrowd(2);
    config.separation_distance = separation_distance;
    AgentCrowd crowd(config, kHalfExtent);
    crowd.placeAgent(0, Eigen::Vector3f(-5.0f, -0.25f, 0.0f), Eigen::Vector3f(6.0f, -0.25f, 0.0f));
    crowd.placeAgent(1, Eigen::Vector3f(-5.0f, 0.25f, 0.0f), Eigen::Vector3f(6.0f, 0.25f, 0.0f));
    for (int frame = 0; frame < 30; ++frame) crowd.runFrame({});
    return (crowd.positions()[1] - crowd.positions()[0]).norm();
  };
  EXPECT_NEAR(gapAfterFlight(0.0f), 0.5f, 1e-4f);
  EXPECT_GT(gapAfterFlight(1.5f), 1.0f);
}

TEST(AgentCrowd, AnAgentCaughtByABoxIsPushedOut) {
  const AiConfig config = smallCrowd(1);
  AgentCrowd crowd(config, kHalfExtent);
  crowd.placeAgent(0, Eigen::Vector3f(0.5f, 0.0f, 0.0f), Eigen::Vector3f(5.0f, 0.0f, 0.0f));
  const Obstacle box{Eigen::Vector3f::Zero(), 1.0f};
  crowd.runFrame({&box, 1});
  EXPECT_GE(crowd.positions()[0].norm(), box.radius + config.agent_radius - 1e-5f);
  EXPECT_EQ(crowd.work().penetrations_resolved, 1u);
}

TEST(AgentCrowd, SameSeedGivesTheSameAgents) {
  auto simulate = [](std::uint64_t seed) {
    AiConfig config = smallCrowd(48);
    config.seed = seed;
    AgentCrowd crowd(config, kHalfExtent);
    std::vector<Obstacle> boxes = randomBoxes(9, 40);
    for (int frame = 0; frame < 60; ++frame) {
      drift(boxes, frame);
      crowd.runFrame(boxes);
    }
    return crowd.checksum();
  };
  EXPECT_EQ(simulate(1), simulate(1));
  EXPECT_NE(simulate(1), simulate(2));
}

// --task-load 0 makes a crowd of no agents: it runs frames and hashes to the
// empty hash (it once read through the empty vector's null data pointer).
TEST(AgentCrowd, NoAgentsRunAndHashToTheEmptyHash) {
  AgentCrowd crowd(smallCrowd(0), kHalfExtent);
  crowd.runFrame(randomBoxes(9, 40));
  EXPECT_EQ(crowd.checksum(), kFnv1aOffsetBasis);
}

// The engine runs sound and AI as concurrent TBB tasks: each must give
// exactly what it gives on the main thread, with the other running beside it.
TEST(AgentCrowd, TbbTaskGivesTheSameResultAsTheMainThread) {
  const AiConfig ai_config = smallCrowd(64);
  AgentCrowd on_main(ai_config, kHalfExtent);
  AgentCrowd on_task(ai_config, kHalfExtent);
  SoundMixer mixer_on_main{SoundConfig{}};
  SoundMixer mixer_on_task{SoundConfig{}};
  std::vector<Obstacle> boxes = randomBoxes(11, 80);
  std::uint64_t main_sound = kFnv1aOffsetBasis;
  std::uint64_t task_sound = kFnv1aOffsetBasis;
  for (int frame = 0; frame < 30; ++frame) {
    drift(boxes, frame);
    const std::vector<ImpactEvent> impacts(static_cast<std::size_t>(frame % 4),
                                           ImpactEvent{3.0f, 0.2f, 1.0f});
    on_main.runFrame(boxes);
    mixer_on_main.runFrame(impacts);
    main_sound = fnv1a(mixer_on_main.mix(), main_sound);

    tbb::task_group tasks;
    tasks.run([&] { on_task.runFrame(boxes); });
    tasks.run([&] { mixer_on_task.runFrame(impacts); });
    tasks.wait();
    task_sound = fnv1a(mixer_on_task.mix(), task_sound);
  }
  EXPECT_EQ(on_main.checksum(), on_task.checksum());
  EXPECT_EQ(main_sound, task_sound);
}

TEST(AgentCrowd, RejectsANonFiniteBox) {
  AgentCrowd crowd(smallCrowd(4), kHalfExtent);
  std::vector<Obstacle> boxes = randomBoxes(1, 5);
  boxes[3].centre.y() = std::numeric_limits<float>::quiet_NaN();
  try {
    crowd.runFrame(boxes);
    FAIL() << "a NaN box centre was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("box 3"), std::string::npos) << error.what();
  }
}

// A scene of one box has a container about 1 m across, less than the default
// agent radius plus wall margin (1.3 m): the crowd shrinks to fit, it does not
// fail the run.
TEST(AgentCrowd, ShrinksItsAgentsToFitATinyContainer) {
  constexpr float kTiny = 1.0f;
  AgentCrowd crowd(smallCrowd(16), kTiny);
  const std::vector<Obstacle> boxes = {{Eigen::Vector3f(0.2f, -0.5f, 0.1f), 0.4f}};
  for (int frame = 0; frame < 60; ++frame) crowd.runFrame(boxes);
  for (const Eigen::Vector3f& position : crowd.positions()) {
    ASSERT_TRUE(position.allFinite());
    EXPECT_LT(position.cwiseAbs().maxCoeff(), kTiny);
  }
  EXPECT_GT(crowd.work().frames, 0u);
}

TEST(AgentCrowd, RejectsAContainerWithNoInterior) {
  EXPECT_THROW(AgentCrowd(smallCrowd(1), 0.0f), std::invalid_argument);
  EXPECT_THROW(AgentCrowd(smallCrowd(1), std::numeric_limits<float>::quiet_NaN()),
               std::invalid_argument);
}

}  // namespace
}  // namespace overlap::stubs
