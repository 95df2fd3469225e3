// The game loop (engine/runtime/game_session.h): a session without tasks
// steps as the world alone does, the tasks give one state and sound sync or
// async, the callbacks come around each frame in order, a signal stops the
// loop naming the frame, and a finished session steps no more.
#include "engine/runtime/game_session.h"

#include <gtest/gtest.h>

#include <csignal>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "gpu/base/checksum.h"
#include "gpu/base/interrupt.h"
#include "tests/engine/scheduler_test_support.h"

namespace overlap::engine {
namespace {

using testing::smallScene;

std::unique_ptr<physics::PhysicsWorld> smallWorld() {
  return std::make_unique<physics::PhysicsWorld>(smallScene(), physics::WorldOptions{"cpusap"});
}

constexpr int kFrames = 12;

TEST(GameSession, WithoutTasksStepsAsTheWorldAlone) {
  const std::unique_ptr<physics::PhysicsWorld> alone = smallWorld();
  std::vector<int> alone_pairs;
  for (int frame = 0; frame < kFrames; ++frame) alone_pairs.push_back(alone->stepFrame().pairs);

  GameSession session(smallWorld(), {});
  std::vector<int> frames;
  std::vector<int> session_pairs;
  session.runFrames(kFrames, [&](int frame, const ScheduledFrame& scheduled) {
    frames.push_back(frame);
    session_pairs.push_back(scheduled.physics.pairs);
    EXPECT_TRUE(scheduled.task_runs.empty());
  });
  EXPECT_EQ(session_pairs, alone_pairs);
  EXPECT_EQ(session.world().stateHash(), alone->stateHash());
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kFrames));
  for (int frame = 0; frame < kFrames; ++frame) EXPECT_EQ(frames[frame], frame);
  EXPECT_FALSE(session.hasTasks());
  EXPECT_EQ(session.soundChecksum(), kFnv1aOffsetBasis);
  EXPECT_EQ(session.aiChecksum(), 0u);
}

TEST(GameSession, TasksGiveOneStateAndSoundSyncOrAsync) {
  const auto stepped = [](bool sync) {
    auto session = std::make_unique<GameSession>(smallWorld(),
                                                 GameSessionOptions{sync, testing::smallTasks()});
    int task_frames = 0;
    session->runFrames(kFrames, [&](int, const ScheduledFrame& scheduled) {
      task_frames += scheduled.task_runs.size() == 2 ? 1 : 0;
    });
    session->finish();
    EXPECT_EQ(task_frames, kFrames);
    return session;
  };
  const std::unique_ptr<GameSession> async_session = stepped(false);
  const std::unique_ptr<GameSession> sync_session = stepped(true);
  EXPECT_TRUE(async_session->hasTasks());
  EXPECT_NE(async_session->soundChecksum(), kFnv1aOffsetBasis);
  EXPECT_EQ(async_session->soundChecksum(), sync_session->soundChecksum());
  EXPECT_EQ(async_session->aiChecksum(), sync_session->aiChecksum());
  EXPECT_EQ(async_session->world().stateHash(), sync_session->world().stateHash());
}

TEST(GameSession, BeforeComesBeforeTheStepAndAfterAfterIt) {
  GameSession session(smallWorld(), {});
  std::vector<std::string> calls;
  session.runFrames(
      3,
      [&](int frame, const ScheduledFrame& scheduled) {
        calls.push_back("after " + std::to_string(frame) + " of physics frame " +
                        std::to_string(scheduled.physics.frame));
      },
      [&](int frame) { calls.push_back("before " + std::to_string(frame)); });
  EXPECT_EQ(calls, (std::vector<std::string>{"before 0", "after 0 of physics frame 0", "before 1",
                                             "after 1 of physics frame 1", "before 2",
                                             "after 2 of physics frame 2"}));
  EXPECT_EQ(session.timeline().spans().front().name, "frame");
}

TEST(GameSession, ASignalStopsTheLoopNamingTheFrame) {
  GameSession session(smallWorld(), {});
  int stepped = 0;
  try {
    session.runFrames(5, [&](int frame, const ScheduledFrame&) {
      ++stepped;
      if (frame == 1) interrupt_detail::received.store(SIGINT);
    });
    ADD_FAILURE() << "no stop";
  } catch (const Interrupted& stop) {
    EXPECT_EQ(stop.where, "frame 2 of 5");
  }
  interrupt_detail::received.store(0);
  EXPECT_EQ(stepped, 2);
}

TEST(GameSession, AFinishedSessionStepsNoMore) {
  GameSession session(smallWorld(), GameSessionOptions{false, testing::smallTasks()});
  session.runFrames(2, {});
  session.finish();
  session.finish();  // twice is once
  EXPECT_THROW(session.runFrames(1, {}), std::logic_error);
}

}  // namespace
}  // namespace overlap::engine
