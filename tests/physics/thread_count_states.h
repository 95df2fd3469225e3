// The state a run reaches on task systems of different thread counts, for
// the thread-count tests of the coloured solver (fast and long).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "gpu/task_system.h"
#include "physics/world.h"

namespace overlap::physics::testing {

// The thread counts every state is compared over.
inline const std::vector<int>& threadCounts() {
  static const std::vector<int> counts = {1, 2, 3, 8, 16};
  return counts;
}

// stateHash() after `frames` frames of scene `scene` with `objects` boxes and
// CCD `ccd`, on a plain-thread task system of `threads` threads (every
// worker a real thread, also under ThreadSanitizer).
inline std::uint64_t stateAfter(int scene, int objects, int frames, CcdMode ccd, int threads) {
  SceneConfig config = SceneConfig::forScene(scene);
  config.objects = objects;
  config.seed = 42;
  const std::unique_ptr<TaskSystem> tasks = makeTaskSystem(threads, TaskBackEnd::kPlainThreads);
  WorldOptions options{"cpusap"};
  options.solver_order = SolverOrder::kColoured;
  options.ccd = ccd;
  options.tasks = tasks.get();
  PhysicsWorld world(config, options);
  for (int frame = 0; frame < frames; ++frame) world.stepFrame();
  return world.stateHash();
}

// "" when every thread count reaches the one-thread state, else which did not.
inline std::string threadCountsThatDiffer(int scene, int objects, int frames, CcdMode ccd) {
  const std::uint64_t one_thread = stateAfter(scene, objects, frames, ccd, 1);
  std::string differ;
  for (const int threads : threadCounts()) {
    if (threads == 1) continue;
    if (stateAfter(scene, objects, frames, ccd, threads) != one_thread) {
      differ += (differ.empty() ? "" : ", ") + std::to_string(threads) + " threads";
    }
  }
  return differ;
}

// threadCountsThatDiffer() with CCD on every box and with the default CCD:
// "" when both reach one state for every thread count, else where not.
inline std::string whereThreadCountsDiffer(int scene, int objects, int frames) {
  std::string differ;
  for (const CcdMode ccd : {CcdMode::kAll, CcdMode::kAuto}) {
    const std::string counts = threadCountsThatDiffer(scene, objects, frames, ccd);
    if (!counts.empty()) differ += "ccd " + ccdModeName(ccd) + ": " + counts + "; ";
  }
  return differ;
}

}  // namespace overlap::physics::testing
