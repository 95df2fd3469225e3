// physics/task_crew.h's rules, on both task back ends and several thread
// counts (more threads than cores too), with the helpers in and with every
// other thread busy elsewhere.
#include "physics/task_crew.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tests/task_setups.h"

namespace overlap::physics {
namespace {

class TaskCrewTest : public ::testing::TestWithParam<TaskSetup> {
 protected:
  std::unique_ptr<TaskSystem> tasks_ = makeTaskSystem(GetParam().threads, GetParam().back_end);
  std::unique_ptr<TaskGroup> helpers_ = tasks_->makeGroup();
};

using Pieces = std::set<std::pair<std::size_t, std::size_t>>;

// Every piece of [0, count) at `grain`, once each, as forEachPiece must run them.
Pieces expectedPieces(std::size_t count, std::size_t grain) {
  Pieces expected;
  for (std::size_t first = 0; first < count; first += grain) {
    expected.emplace(first, std::min(count, first + grain));
  }
  return expected;
}

TEST_P(TaskCrewTest, EachLoopRunsTheTaskSystemsPiecesOnceEachAndEndsWithThem) {
  TaskCrew crew(*tasks_, *helpers_);
  // Many short loops back to back, as the solver's colours come: a loop's
  // pieces must all have ended, and written, when forEachPiece returns.
  for (int round = 0; round < 50; ++round) {
    for (const std::size_t count : {0u, 1u, 31u, 32u, 33u, 1023u, 1025u, 20000u}) {
      for (const std::size_t grain : {1u, 32u, 1000u}) {
        std::vector<int> visits(count, 0);
        std::mutex mutex;
        Pieces pieces;
        crew.forEachPiece(count, grain, [&](std::size_t first, std::size_t end) {
          for (std::size_t i = first; i < end; ++i) ++visits[i];  // each index one piece's
          const std::lock_guard lock(mutex);
          pieces.emplace(first, end);
        });
        ASSERT_EQ(pieces, expectedPieces(count, grain)) << count << " by " << grain;
        for (std::size_t i = 0; i < count; ++i) ASSERT_EQ(visits[i], 1) << i;
      }
    }
  }
}

TEST_P(TaskCrewTest, PiecesRunOnSeveralThreadsWhenTheSystemHasThem) {
  TaskCrew crew(*tasks_, *helpers_);
  std::mutex mutex;
  std::set<std::thread::id> threads;
  // Pieces that last long enough for a helper to arrive.
  const int rounds = GetParam().threads > 1 ? 200 : 3;
  for (int round = 0; round < rounds && threads.size() < 2; ++round) {
    crew.forEachPiece(64, 1, [&](std::size_t, std::size_t) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      const std::lock_guard lock(mutex);
      threads.insert(std::this_thread::get_id());
    });
  }
  if (GetParam().threads > 1) {
    EXPECT_GE(threads.size(), 2u);
  } else {
    EXPECT_EQ(threads.size(), 1u);
  }
}

TEST_P(TaskCrewTest, ALoopNeverWaitsForAHelperThatIsBusyElsewhere) {
  // Every other thread is held by a job until the crew's loops are done: the
  // caller must run them all alone.
  std::atomic<bool> release{false};
  std::atomic<int> held{0};
  const auto other = tasks_->makeGroup();
  for (int job = 1; job < GetParam().threads; ++job) {
    other->run([&] {
      held.fetch_add(1);
      while (!release.load()) std::this_thread::yield();
    });
  }
  // oneTBB starts no more workers than the machine has hardware threads, so
  // on a small machine some of the jobs wait: at least one must be holding
  // its thread (with two threads, the crew's only other one).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (held.load() < GetParam().threads - 1 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::yield();
  }
  if (GetParam().threads > 1) {
    EXPECT_GE(held.load(), 1);
  }
  {
    TaskCrew crew(*tasks_, *helpers_);
    std::atomic<std::size_t> ran{0};
    for (int round = 0; round < 100; ++round) {
      crew.forEachPiece(100, 7, [&](std::size_t first, std::size_t end) { ran += end - first; });
    }
    EXPECT_EQ(ran.load(), 100u * 100u);
  }
  release.store(true);
  other->wait();
  helpers_->wait();  // the late helper jobs find the crew ended and return
}

TEST_P(TaskCrewTest, APieceThatThrowsEndsTheLoopWithItsErrorAndTheCrewGoesOn) {
  TaskCrew crew(*tasks_, *helpers_);
  std::atomic<int> ran{0};
  EXPECT_THROW(crew.forEachPiece(1000, 1,
                                 [&](std::size_t first, std::size_t) {
                                   ran.fetch_add(1);
                                   if (first == 3) throw std::runtime_error("piece 3");
                                 }),
               std::runtime_error);
  std::atomic<std::size_t> after{0};
  crew.forEachPiece(1000, 10, [&](std::size_t first, std::size_t end) { after += end - first; });
  EXPECT_EQ(after.load(), 1000u);
}

TEST_P(TaskCrewTest, CrewsComeAndGoOnOneGroup) {
  // The solver makes a crew a call, on one group, many times a frame.
  for (int call = 0; call < 300; ++call) {
    TaskCrew crew(*tasks_, *helpers_);
    std::atomic<std::size_t> ran{0};
    crew.forEachPiece(256, 32, [&](std::size_t first, std::size_t end) { ran += end - first; });
    ASSERT_EQ(ran.load(), 256u) << call;
  }
  helpers_->wait();
}

INSTANTIATE_TEST_SUITE_P(BackEnds, TaskCrewTest, ::testing::ValuesIn(taskSetups()), taskSetupName);

}  // namespace
}  // namespace overlap::physics
