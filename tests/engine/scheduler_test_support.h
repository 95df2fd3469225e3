// The demo's frame for tests: a small scene 4, and a scheduler with the
// sound and AI tasks at a small size, so a scheduled run of the small scene
// costs about what its physics does.
#pragma once

#include "engine/runtime/frame_scheduler.h"
#include "engine/runtime/sound_and_ai.h"
#include "engine/runtime/timeline.h"
#include "physics/scene.h"

namespace overlap::engine::testing {

// Scene 4 with 120 boxes: a few frames of it take milliseconds.
inline physics::SceneConfig smallScene() {
  physics::SceneConfig config = physics::SceneConfig::forScene(4);
  config.objects = 120;
  return config;
}

inline SoundAndAiOptions smallTasks() {
  SoundAndAiOptions options;
  options.sound.voices = 8;
  options.sound.background_voices = 4;
  options.ai.agents = 32;
  return options;
}

// `world`'s frame with the small tasks registered; sync runs the jobs one
// after another.
struct DemoFrame {
  DemoFrame(physics::PhysicsWorld& world, bool sync)
      : scheduler(world, SchedulerOptions{sync}, timeline), tasks(world, smallTasks(), scheduler) {}

  Timeline timeline;
  FrameScheduler scheduler;
  SoundAndAi tasks;
};

}  // namespace overlap::engine::testing
