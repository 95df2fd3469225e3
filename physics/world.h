// The Bullet adapter: a scene living in a btDiscreteDynamicsWorld.
//
// PhysicsWorld builds the scene (boxes and six static walls, nothing else),
// steps it one frame at a time (K substeps of frame_time / K, K fixed or
// chosen each frame with the CCD bodies by physics/step_policy.h, which also
// sets up Bullet's contact solver: solverSettings()), and
// reports what the frame cost and what it got wrong.  Each substep runs its
// phases in the order physics/timed_world.h lists them; each phase's time is
// summed over the substeps, and each substep reports when it ran, when its
// pair search ran and when its narrowphase ran.  One PhysicsWorld is used
// from one thread; inside stepFrame its parallel parts (the CPU search, the
// narrowphase, the contact solver's coloured batches, the per-body phases)
// run on WorldOptions::tasks, and nothing runs after it returns.
//
// A box whose state breaks (not finite, an AABB too large for Bullet, too
// far away) leaves the simulation where it is found, with one message:
// nothing in Bullet names it after that (TimedDynamicsWorld::removeBody),
// and it is out of every report.
//
// Invariants: box i of the layout is rigid body i; the walls come after the
// boxes; the same config and options give bit-identical runs (stateHash()).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gpu/pair_finder.h"
#include "physics/aabb.h"
#include "physics/frame_report.h"
#include "physics/scene.h"
#include "physics/step_policy.h"

class btBroadphaseInterface;
class btDiscreteDynamicsWorld;

namespace overlap::physics {

struct WorldOptions {
  std::string algorithm = "bvh";
  int substeps = kAutoSubsteps;  // kAutoSubsteps: chooseSubsteps() each frame; else fixed K
  CcdMode ccd = CcdMode::kAuto;  // Bullet's swept-sphere CCD: none, chooseCcdBodies(), every box
  SleepMode sleep = SleepMode::kScene;    // Bullet's deactivation, sleepAllowed()
  SolverMode solver = SolverMode::kPile;  // Bullet's contact solver, solverSettings()
  // The contact solver's sweep: batches on the task system, or Bullet's
  // serial solver (physics/coloured_solver.h).  Coloured by default: on
  // this project's 2-core machine the two take the same time on one thread
  // and the coloured sweep the less on two (docs/results/thread_scaling.csv);
  // its error next to Bullet's is in docs/results/solver_order_error.md, and
  // a pile sleeps with either order (docs/results/solver_order_sleep.csv).
  SolverOrder solver_order = SolverOrder::kColoured;
  // The threads the step's parallel parts and a CPU search run on; it must
  // outlive the world.  Null: defaultTaskSystem().
  TaskSystem* tasks = nullptr;
  NarrowphaseMode narrowphase = NarrowphaseMode::kBesideSearch;
};

struct BoxPose {
  float centre[3];
  float orientation[4];  // x, y, z, w
  float edge;
  SizeClass size_class;
  bool in_contact;
};

// Two bodies that began touching during the last frame: their contact
// manifold gained its first point in some substep's narrowphase.  It follows
// the physics, not the broadphase (a fattened AABB pair is no contact), so
// every broadphase reports the same contacts.  Walls are numbered after the
// boxes, and two walls never touch, so `a` is always a box.
struct NewContact {
  int a;  // a < b
  int b;
  float closing_speed;  // m/s, before that substep's solver, along the line
                        // between the centres (walls: their normal)
  float centre[3];      // box a's centre at that narrowphase
  float edge;           // the smaller box's edge
};

// What the world is after its last frame (or its building, or an
// injectBoxPosition), filled once: everything read of the boxes between
// frames comes from here, so nothing rescans the world (Box2D's move and
// begin-touch events are the model).  Changes made through bulletWorld()
// show after the next frame.
struct FrameRecord {
  std::vector<BoxPose> poses;      // the boxes in the simulation, in box order
  std::vector<float> speeds;       // per box, m/s; 0 for a box out of the simulation
  std::vector<int> moved;          // the boxes whose pose changed in the frame, ascending
  std::vector<NewContact> began;   // contacts that began in the frame, by substep, then (a, b)
  double deepest_penetration = 0;  // the deepest contact overlap / the smaller box's edge
};

class PhysicsWorld {
 public:
  PhysicsWorld(const SceneConfig& config, const WorldOptions& options);
  ~PhysicsWorld();
  PhysicsWorld(const PhysicsWorld&) = delete;
  PhysicsWorld& operator=(const PhysicsWorld&) = delete;

  // Runs one frame: scene forces (kicks, gravity), then K substeps, then
  // takes out any box the last substep broke (so no broken box is seen
  // between frames).  A signal (gpu/base/interrupt.h) stops a long frame
  // between substeps or after a substep's pair search with Interrupted; the
  // world is then only to be destroyed.  Building the world (placing the
  // boxes, adding them to Bullet) stops the same way, and destroying it is
  // linear in the boxes and pairs.
  FrameReport stepFrame();

  const SceneConfig& config() const { return config_; }
  const SceneLayout& layout() const { return layout_; }
  // The fixed K, or with automatic substeps the K of the last frame (0 before the first).
  int substeps() const { return substeps_; }
  bool automaticSubsteps() const { return automatic_substeps_; }
  int framesDone() const { return frame_; }
  const std::string& algorithm() const { return algorithm_; }
  const std::string& algorithmNotice() const { return algorithm_notice_; }
  TaskSystem& tasks() const { return tasks_; }

  // FNV-1a over every box's position, rotation and velocities.
  std::uint64_t stateHash() const;
  // FNV-1a over every contact manifold in the dispatcher's order: its two
  // bodies, then each point's positions, normal, depth, impulse and age, so
  // two runs compare contact for contact.
  std::uint64_t contactHash() const;
  // The last frame's record, and its parts by name.
  const FrameRecord& record() const { return record_; }
  const std::vector<BoxPose>& boxPoses() const { return record_.poses; }
  const std::vector<float>& boxSpeeds() const { return record_.speeds; }
  // The broadphase's current AABBs, boxes then walls.
  std::vector<Aabb> aabbs() const;
  // Overlapping pairs of the world's own bodies in the cache, sorted; walls
  // are numbered after the boxes (objects added through bulletWorld() are
  // left out).
  PairList cachedPairs() const;

  const std::vector<NewContact>& newContacts() const { return record_.began; }

  // Puts box `box` at `position` (any value, NaN included), for hard cases:
  // a box whose state is unusable leaves the simulation at once, with a
  // message, as one a step broke would.
  void injectBoxPosition(int box, const Eigen::Vector3d& position);

  // Bullet's world, for what this class does not wrap.  Up to 64 objects of
  // your own may be added (a btPairCachingGhostObject sees the boxes that
  // enter it under every broadphase; give such objects a user index of -1, the
  // default, and they are left out of the error counts and the new contacts).  Do not
  // replace the pair cache's ghost-pair callback: the world's forwards to
  // Bullet's btGhostPairCallback already.
  btDiscreteDynamicsWorld& bulletWorld();
  // The broadphase asked for, which finds the pairs (CCD's sweeps go
  // through a tree shared by every broadphase: CcdQueryBroadphase).
  btBroadphaseInterface& broadphase();

 private:
  struct Bullet;
  void buildWorld(const WorldOptions& options);
  // "frame 12, substep 2 of 4": where a signal stopped a frame.
  std::string substepName(int substep) const;
  void addBoxes(bool sleep);
  void addWalls();
  void applySceneForces();
  void planFrame(FrameReport& report);
  // The record, and with `report` the frame's counts and energy, in one pass
  // over the manifolds and one over the boxes (on the task system).
  void recordFrame(FrameReport* report);
  void removeBrokenBoxes();
  void noteContactsStarted();

  SceneConfig config_;
  SceneLayout layout_;
  int substeps_;
  bool automatic_substeps_;
  CcdMode ccd_;
  int frame_ = 0;
  TaskSystem& tasks_;
  std::string algorithm_;
  std::string algorithm_notice_;
  std::unique_ptr<Bullet> bullet_;
  FrameRecord record_;
  std::vector<BoxPose> all_poses_;  // per box, the last record's (removed ones too)
};

}  // namespace overlap::physics
