// Scheduler options for tests: the sound and AI tasks at a small size, so a
// scheduled run of a small scene costs about what its physics does.
#pragma once

#include "engine/frame_scheduler.h"

namespace overlap::engine::testing {

inline SchedulerOptions smallTasks(bool sync) {
  SchedulerOptions options;
  options.sync = sync;
  options.sound.voices = 8;
  options.sound.background_voices = 4;
  options.ai.agents = 32;
  return options;
}

}  // namespace overlap::engine::testing
