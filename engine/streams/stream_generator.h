// `overlap generate`'s model: a scene's boxes moving as the scene moves, as a
// .aabbs stream, in seconds and without Bullet.
//
// The boxes are those of physics::generateScene() (the same sizes, start
// positions, orientations and velocities as the simulated scene).  Each is a
// point mass with a spin; they do not collide with each other.  Instead the
// boxes' volume is counted on a uniform grid every substep, and where it
// packs more densely than a random pile of boxes does, a pressure pushes the
// boxes apart (a granular "fluid", particle-in-cell style): a falling cloud
// stays free, a pile forms where gravity drives the boxes, keeps about a pile's
// density, and flows when gravity turns.  Walls stop the boxes with Coulomb
// friction; boxes inside a pile are damped (the pile's friction); a box that
// stays slower than Bullet's sleeping threshold for Bullet's 2 s sleeps (scenes 1
// and 2, as the simulation lets them) and keeps its AABB until kicked.
//   scene 1: gravity -y, the cloud falls and settles into a sleeping layer;
//   scene 2: the same, with `kicks_per_frame` boxes given a new random
//            velocity each frame (woken);
//   scenes 3, 4: 50 g turned by physics::GravityRotation: a dense pile swept
//            around the container.
// A box's AABB is its cube's, turned by its orientation.
//
// Invariants: the same config, frames and skip give the same stream on every
// run and thread count (the grid sums are integers; every box's update reads
// only the grid and its own state); every box stays inside the interior, so
// every AABB is finite with min <= max and the .aabbs reader accepts it.
// It lives in engine/ because it needs the scene's start (physics/scene.h)
// and the stream type (physics/aabb_stream.h), which gpu/ may not include,
// yet it calls nothing of Bullet's.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gpu/task_system.h"
#include "physics/aabb_stream.h"
#include "physics/scene.h"

namespace overlap::engine {

// "overlap generate scene S seed X (granular model, no Bullet)".
std::string generatedSceneName(const physics::SceneConfig& config);

// The stream one frame at a time, so a writer holds one frame, not the
// whole stream: the start and `frames` frames after it, the first `skip`
// frames (after the start) run but not stored: frame 0 of the stream is the
// scene after `skip` frames.  With `moving_share` below 1, only that share of
// the boxes (a seeded draw) moves in the stored frames; the others keep
// frame 0's AABB (a stream for "work in proportion to what moved").  Throws
// std::invalid_argument for a config generateScene() refuses.
// Use: step() stepsToStart() times, frame() (frame 0), then step() and
// frame() until done(); each step is one frame of the model, so a caller
// checks for signals and shows progress between them.  A signal
// (gpu/base/interrupt.h) also stops a step between its substeps, with
// Interrupted.
class GranularModel;  // engine/streams/stream_generator.cpp

class StreamGenerator {
 public:
  // The model's loops run on `tasks`, which must outlive the generator.
  StreamGenerator(const physics::SceneConfig& config, int frames, int skip = 0,
                  double moving_share = 1.0, TaskSystem& tasks = defaultTaskSystem());
  ~StreamGenerator();
  StreamGenerator(const StreamGenerator&) = delete;
  StreamGenerator& operator=(const StreamGenerator&) = delete;

  const physics::AabbStreamHeader& header() const { return header_; }
  int stepsToStart() const { return steps_ < skip_ ? skip_ - steps_ : 0; }
  bool done() const { return steps_ == skip_ + frames_; }
  // Runs the model one frame on.
  void step();
  // The model's substeps per frame: as many as its pressure needs to stay
  // stable, at most physics::SubstepRule's max_substeps (the simulation's
  // cap; past it the pile is softer).
  int substepsPerFrame() const;
  // The boxes of the stored frame the model is at, into `boxes`.
  void frame(std::vector<physics::Aabb>& boxes);

 private:
  int frames_;
  int skip_;
  int steps_ = 0;
  physics::AabbStreamHeader header_;
  std::unique_ptr<GranularModel> model_;
  std::vector<std::uint8_t> moving_;  // per box: 1 if it moves after frame 0
  std::vector<physics::Aabb> start_;  // frame 0's boxes
};

// The whole stream in memory, through StreamGenerator.
physics::AabbStream generateStream(const physics::SceneConfig& config, int frames, int skip = 0,
                                   double moving_share = 1.0,
                                   TaskSystem& tasks = defaultTaskSystem());

}  // namespace overlap::engine
