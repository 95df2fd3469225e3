// Runs of one scene under each narrowphase mode, frame by frame, for the
// narrowphase tests (fast and long): the contacts after each frame and the
// state at the end.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "gpu/task_system.h"
#include "physics/world.h"

namespace overlap::physics::testing {

struct ContactRun {
  std::string algorithm;                // what ran (a device finder may fall back)
  std::vector<std::uint64_t> contacts;  // contactHash() after each frame
  std::uint64_t state = 0;              // stateHash() after the last
};

inline ContactRun runContacts(const std::string& algorithm, NarrowphaseMode mode, TaskSystem& tasks,
                              int scene, int boxes, int frames, CcdMode ccd = CcdMode::kAuto) {
  SceneConfig config = SceneConfig::forScene(scene);
  config.objects = boxes;
  WorldOptions options{algorithm, kAutoSubsteps, ccd};
  options.tasks = &tasks;
  options.narrowphase = mode;
  PhysicsWorld world(config, options);
  ContactRun run;
  run.algorithm = world.algorithm();
  for (int frame = 0; frame < frames; ++frame) {
    world.stepFrame();
    run.contacts.push_back(world.contactHash());
  }
  run.state = world.stateHash();
  return run;
}

// The first frame whose contacts differ, or -1.
inline int firstDifferentFrame(const ContactRun& a, const ContactRun& b) {
  for (std::size_t f = 0; f < a.contacts.size() && f < b.contacts.size(); ++f) {
    if (a.contacts[f] != b.contacts[f]) return static_cast<int>(f);
  }
  return a.contacts.size() == b.contacts.size() ? -1 : static_cast<int>(a.contacts.size());
}

}  // namespace overlap::physics::testing
