// The job graph on its own: dependencies kept in both orders, the refused
// graphs, and errors that leave nothing in flight.
#include "engine/runtime/job_graph.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace overlap::engine {
namespace {

// Records the order the jobs started and ended in, from any thread.
class Log {
 public:
  std::function<void()> job(std::string name) {
    return [this, name] {
      const std::lock_guard lock(mutex_);
      events_.push_back(name);
    };
  }
  std::vector<std::string> events() const { return events_; }

 private:
  std::mutex mutex_;
  std::vector<std::string> events_;
};

// first (main) -> a -> b (workers); c (workers, free); last (main, after first).
TEST(JobGraph, EveryJobRunsOnceAfterItsDependenciesInBothOrders) {
  for (const bool sync : {false, true}) {
    SCOPED_TRACE(sync ? "sync" : "async");
    Log log;
    JobGraph graph(defaultTaskSystem());
    const JobId first = graph.add("first", JobThread::kMain, log.job("first"));
    const JobId a = graph.add("a", JobThread::kWorkers, log.job("a"), {first});
    graph.add("b", JobThread::kWorkers, log.job("b"), {a});
    graph.add("c", JobThread::kWorkers, log.job("c"));
    graph.add("last", JobThread::kMain, log.job("last"), {first});
    for (int run = 0; run < 20; ++run) {
      graph.run(sync);
      EXPECT_EQ(log.events().size(), 5u * static_cast<std::size_t>(run + 1));
    }
    const std::vector<std::string> events = log.events();
    for (std::size_t run = 0; run < 20; ++run) {
      const std::vector<std::string> one(events.begin() + static_cast<long>(5 * run),
                                         events.begin() + static_cast<long>(5 * run + 5));
      const auto at = [&](const char* name) { return std::find(one.begin(), one.end(), name); };
      EXPECT_LT(at("first"), at("a"));
      EXPECT_LT(at("a"), at("b"));
      EXPECT_LT(at("first"), at("last"));
      if (sync) {
        EXPECT_EQ(one, (std::vector<std::string>{"first", "a", "b", "c", "last"}));
      }
    }
    EXPECT_EQ(graph.lastWorkers().has_value(), !sync);
    EXPECT_EQ(graph.lastJoin().has_value(), !sync);
  }
}

TEST(JobGraph, RefusesADependencyNotYetAddedAndAMainJobAfterAWorker) {
  JobGraph graph(defaultTaskSystem());
  EXPECT_THROW(graph.add("ahead", JobThread::kWorkers, [] {}, {0}), std::invalid_argument);
  const JobId worker = graph.add("worker", JobThread::kWorkers, [] {});
  EXPECT_THROW(graph.add("main", JobThread::kMain, [] {}, {worker}), std::invalid_argument);
  EXPECT_EQ(graph.size(), 1u);
}

// A worker's error is kept and its siblings and dependents still run; a
// main job's error leaves run() only once every started worker has ended.
TEST(JobGraph, ErrorsLeaveNothingInFlight) {
  for (const bool sync : {false, true}) {
    SCOPED_TRACE(sync ? "sync" : "async");
    std::atomic<int> ran{0};
    JobGraph graph(defaultTaskSystem());
    const JobId failing =
        graph.add("failing", JobThread::kWorkers, [] { throw std::runtime_error("out of tune"); });
    const JobId after = graph.add("after", JobThread::kWorkers, [&ran] { ++ran; }, {failing});
    graph.run(sync);
    EXPECT_EQ(graph.lastError(failing), "out of tune");
    EXPECT_EQ(graph.lastError(after), "");
    EXPECT_EQ(ran.load(), 1);

    graph.add("slow", JobThread::kWorkers, [&ran] {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      ++ran;
    });
    graph.add("step", JobThread::kMain, [] { throw std::runtime_error("the step failed"); });
    EXPECT_THROW(graph.run(sync), std::runtime_error);
    EXPECT_EQ(ran.load(), 3) << "the slow job ended before run() left";
  }
}

}  // namespace
}  // namespace overlap::engine
