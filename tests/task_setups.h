// The task systems a parameterised test runs on: each back end at several
// thread counts (more threads than cores too: the plain back end starts
// every one), named for the test's output.  Under ThreadSanitizer only the
// plain back end: Debian's oneTBB is not instrumented (gpu/task_system.h).
#pragma once

#include <gtest/gtest.h>

#include <ostream>
#include <string>
#include <vector>

#include "gpu/task_system.h"

namespace overlap {

struct TaskSetup {
  TaskBackEnd back_end;
  int threads;
};

// What gtest prints for a setup (ctest's test list, a failure).
inline void PrintTo(const TaskSetup& setup, std::ostream* out) {
  *out << (setup.back_end == TaskBackEnd::kOneTbb ? "oneTBB, " : "plain threads, ") << setup.threads
       << (setup.threads == 1 ? " thread" : " threads");
}

inline std::string taskSetupName(const ::testing::TestParamInfo<TaskSetup>& info) {
  return std::string(info.param.back_end == TaskBackEnd::kOneTbb ? "OneTbb" : "PlainThreads") +
         std::to_string(info.param.threads);
}

inline std::vector<TaskSetup> taskSetups() {
  std::vector<TaskSetup> setups;
#ifndef OVERLAP_PLAIN_THREAD_TASKS
  for (const int threads : {1, 2, 4}) setups.push_back({TaskBackEnd::kOneTbb, threads});
#endif
  for (const int threads : {1, 2, 3, 8}) setups.push_back({TaskBackEnd::kPlainThreads, threads});
  return setups;
}

}  // namespace overlap
