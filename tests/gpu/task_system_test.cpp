// gpu/task_system.h's rules, for both back ends and several thread counts
// (more threads than cores too: the plain back end starts every one).
#include "gpu/task_system.h"

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

namespace overlap {
namespace {

class TaskSystemTest : public ::testing::TestWithParam<TaskSetup> {
 protected:
  std::unique_ptr<TaskSystem> tasks_ = makeTaskSystem(GetParam().threads, GetParam().back_end);
};

using Pieces = std::set<std::pair<std::size_t, std::size_t>>;

TEST_P(TaskSystemTest, PiecesDependOnTheCountAndGrainAloneAndCoverEachIndexOnce) {
  for (const std::size_t count : {0u, 1u, 31u, 32u, 33u, 1023u, 1025u, 100000u}) {
    for (const std::size_t grain : {1u, 32u, 1000u}) {
      std::vector<std::atomic<int>> visits(count);
      std::mutex mutex;
      Pieces pieces;
      tasks_->forEachPiece(count, grain, [&](std::size_t first, std::size_t end) {
        for (std::size_t i = first; i < end; ++i) visits[i].fetch_add(1);
        const std::lock_guard lock(mutex);
        pieces.emplace(first, end);
      });
      Pieces expected;
      for (std::size_t first = 0; first < count; first += grain) {
        expected.emplace(first, std::min(count, first + grain));
      }
      EXPECT_EQ(pieces, expected) << count << " by " << grain;
      EXPECT_EQ(pieces.size(), pieceCount(count, grain));
      for (std::size_t i = 0; i < count; ++i) ASSERT_EQ(visits[i].load(), 1) << i;
    }
  }
}

TEST_P(TaskSystemTest, ThreadIndicesAreInRangeAndDistinctBetweenPiecesRunningAtOnce) {
  const int threads = tasks_->threads();
  EXPECT_EQ(threads, GetParam().threads);
  std::vector<std::atomic<int>> busy(static_cast<std::size_t>(threads));
  std::atomic<bool> shared{false}, out_of_range{false};
  tasks_->forEachPiece(64, 1, [&](std::size_t, std::size_t) {
    const int index = tasks_->threadIndex();
    if (index < 0 || index >= threads) {
      out_of_range = true;
      return;
    }
    if (busy[static_cast<std::size_t>(index)].fetch_add(1) != 0) shared = true;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
    busy[static_cast<std::size_t>(index)].fetch_sub(1);
  });
  EXPECT_FALSE(out_of_range);
  EXPECT_FALSE(shared) << "two live pieces had one thread index";
}

TEST_P(TaskSystemTest, APieceThatThrowsEndsTheLoopWithItsError) {
  std::atomic<int> ran{0};
  EXPECT_THROW(tasks_->forEachPiece(1000, 1,
                                    [&](std::size_t first, std::size_t) {
                                      ran.fetch_add(1);
                                      if (first == 3) throw std::runtime_error("piece 3");
                                    }),
               std::runtime_error);
  EXPECT_GE(ran.load(), 1);
  // The system still works after it.
  std::atomic<int> after{0};
  tasks_->forEachPiece(10, 1, [&](std::size_t, std::size_t) { after.fetch_add(1); });
  EXPECT_EQ(after.load(), 10);
}

TEST_P(TaskSystemTest, LoopsNestAndRunInsideGroupJobs) {
  std::atomic<long> sum{0};
  const std::unique_ptr<TaskGroup> group = tasks_->makeGroup();
  for (int job = 0; job < 4; ++job) {
    group->run([&] {
      tasks_->forEachPiece(10, 1, [&](std::size_t outer, std::size_t) {
        tasks_->forEachPiece(10, 3, [&](std::size_t first, std::size_t end) {
          for (std::size_t inner = first; inner < end; ++inner) {
            sum.fetch_add(static_cast<long>(outer * 10 + inner));
          }
        });
      });
    });
  }
  group->wait();
  EXPECT_EQ(sum.load(), 4 * 4950);
}

TEST_P(TaskSystemTest, AGroupRunsEveryJobAndRethrowsTheFirstError) {
  std::atomic<int> ran{0};
  const std::unique_ptr<TaskGroup> group = tasks_->makeGroup();
  for (int job = 0; job < 20; ++job) group->run([&] { ran.fetch_add(1); });
  group->wait();
  EXPECT_EQ(ran.load(), 20);
  group->run([] { throw std::runtime_error("job failed"); });
  group->run([&] { ran.fetch_add(1); });
  EXPECT_THROW(group->wait(), std::runtime_error);
  EXPECT_EQ(ran.load(), 21) << "a failed job does not cancel its sibling";
  group->wait();  // the error was handed over once
}

TEST_P(TaskSystemTest, AGroupWaitsForItsJobsWhenItGoes) {
  std::atomic<bool> ended{false};
  {
    const std::unique_ptr<TaskGroup> group = tasks_->makeGroup();
    group->run([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      ended = true;
    });
  }
  EXPECT_TRUE(ended.load());
}

INSTANTIATE_TEST_SUITE_P(BackEnds, TaskSystemTest, ::testing::ValuesIn(taskSetups()),
                         taskSetupName);

TEST(TaskSystem, RefusesANegativeThreadCountAndTakesZeroAsEveryHardwareThread) {
  EXPECT_THROW(makeTaskSystem(-1), std::invalid_argument);
  EXPECT_GE(makeTaskSystem(0)->threads(), 1);
  EXPECT_EQ(defaultTaskSystem().threads(), makeTaskSystem(0)->threads());
}

TEST(TaskSystem, GrainForMakesAboutTheAskedPiecesAndNeverLessThanTheLeast) {
  EXPECT_EQ(grainFor(1000, 2, 5, 1), 100u);
  EXPECT_EQ(grainFor(1000, 2, 5, 300), 300u);
  EXPECT_EQ(grainFor(0, 4, 8, 0), 1u);
  EXPECT_EQ(pieceCount(1000, grainFor(1000, 4, 8, 1)), 32u);
}

}  // namespace
}  // namespace overlap
