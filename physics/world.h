// The Bullet adapter: a scene living in a btDiscreteDynamicsWorld.
//
// PhysicsWorld builds the scene (boxes and six static walls, nothing else),
// steps it one frame at a time (K fixed substeps of frame_time / K), and
// reports what the frame cost and what it got wrong.  Times are taken inside
// Bullet's step: AABB update, broadphase (pair search and pair-cache update),
// narrowphase, solver and integration are each summed over the substeps.
// Bullet is not thread-safe here: one PhysicsWorld is used from one thread.
//
// Invariants: box i of the layout is rigid body i; the walls come after the
// boxes; the same config and options give bit-identical runs (stateHash()).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "physics/scene.h"

class btBroadphaseInterface;
class btDiscreteDynamicsWorld;

namespace overlap::physics {

struct WorldOptions {
  std::string algorithm = "bvh";
  int substeps = 0;  // 0: the scene's default, defaultSubsteps()
  bool ccd = false;  // Bullet's continuous collision detection for every box
};

// Substeps that keep every box inside the container in 2048 frames (README).
int defaultSubsteps(const SceneConfig& config);

struct FrameTimings {
  double update_ms = 0;       // AABBs written into the broadphase
  double broadphase_ms = 0;   // pair search and pair-cache update
  double narrowphase_ms = 0;  // contact generation for the cached pairs
  double solver_ms = 0;       // constraint solver
  double integrate_ms = 0;    // motion prediction and integration
  double total_ms = 0;        // the whole frame
};

struct FrameReport {
  int frame = 0;
  FrameTimings timings;
  int pairs = 0;                    // overlapping pairs in the cache after the frame
  int escaped = 0;                  // boxes whose centre is beyond a wall's outer face
  int sunk = 0;                     // boxes whose centre is outside the interior
  double max_penetration = 0;       // deepest contact overlap / that box's edge
  int removed_from_simulation = 0;  // boxes Bullet disabled (non-finite or huge AABB)
};

struct BoxPose {
  float centre[3];
  float orientation[4];  // x, y, z, w
  float edge;
  SizeClass size_class;
  bool in_contact;
};

struct Aabb {
  float min[3];
  float max[3];
};

class PhysicsWorld {
 public:
  PhysicsWorld(const SceneConfig& config, const WorldOptions& options);
  ~PhysicsWorld();
  PhysicsWorld(const PhysicsWorld&) = delete;
  PhysicsWorld& operator=(const PhysicsWorld&) = delete;

  // Runs one frame: scene forces (kicks, gravity), then K substeps.
  FrameReport stepFrame();

  const SceneConfig& config() const { return config_; }
  const SceneLayout& layout() const { return layout_; }
  int substeps() const { return substeps_; }
  int framesDone() const { return frame_; }
  const std::string& algorithm() const { return algorithm_; }
  const std::string& algorithmNotice() const { return algorithm_notice_; }

  // FNV-1a over every box's position, rotation and velocities.
  std::uint64_t stateHash() const;
  std::vector<BoxPose> boxPoses() const;
  // The broadphase's current AABBs, boxes then walls.
  std::vector<Aabb> aabbs() const;
  // Overlapping pairs in the cache as (min index, max index), sorted; walls
  // are numbered after the boxes.
  std::vector<std::pair<int, int>> cachedPairs() const;

  btDiscreteDynamicsWorld& bulletWorld();
  btBroadphaseInterface& broadphase();

 private:
  struct Bullet;
  void applySceneForces();
  void measureContainment(FrameReport& report) const;

  SceneConfig config_;
  SceneLayout layout_;
  int substeps_;
  int frame_ = 0;
  std::string algorithm_;
  std::string algorithm_notice_;
  std::unique_ptr<Bullet> bullet_;
};

}  // namespace overlap::physics
