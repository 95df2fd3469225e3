// The coloured contact solver: Bullet's sequential-impulse solver with its
// contact rows solved in parallel on the task system, with a result that
// does not depend on the thread count (SolverOrder::kColoured; kSerial keeps
// Bullet's stock btSequentialImpulseConstraintSolver).
//
// Bullet's rows and their setup are kept, call for call: the bodies are
// converted by Bullet's internalConvertBodies, the rows allocated and set up
// by btSequentialImpulseConstraintSolverMt's internalAllocContactConstraints
// and internalSetupContactConstraints, solved by the same row functions
// (resolveSingleConstraintRowLowerLimit, ...Generic, resolveSplitPenetration-
// Impulse) and written back by writeBackContacts and writeBackBodies.  What
// changes is the order.  Bullet's serial solver sweeps the rows in manifold
// order; here each solveGroup call splits the group's moving bodies into up to
// kRegions regions and sweeps the manifolds in batches: the regions'
// interiors, then the manifolds across each split (the last split's first),
// then the walls.  A batch is made of pieces that share no moving body, run
// in parallel; a piece is swept serially, Gauss-Seidel as Bullet sweeps.
// The colours of a graph colouring are the batches' part here: one colour a
// batch, its pieces a colour's disjoint sets.  (A colour for each manifold
// put the two cores' solver bodies in each other's caches after every
// colour: on this project's 2-core machine Bullet's row functions took 1.8x
// the CPU time on two threads; a region's bodies stay on the thread that
// sweeps it.)  Debian's Bullet is not a BT_THREADSAFE build, so btParallelFor
// (and with it Bullet's own Mt solver) runs serially; these loops run on the
// task system instead.  Bullet's own Mt solver batches its constraints alike
// (btBatchedConstraints: phases of batches, each batch serial).
//
// Invariants, each with its reason:
// - The regions and batches depend on the group alone (its manifolds, their
//   order and bodies, the bodies' positions), never on the thread count.
//   Each part of the moving bodies is halved at the median of its widest
//   axis (ties broken by the body's place in the group, positions compared
//   in IEEE-754's total order, NaN included), kRegionLevels times or while
//   a region keeps kBodiesPerRegion bodies.  A manifold between two bodies of one region is
//   in that region's interior piece; one across a split in a piece of the
//   part that split halved: for the last split a piece a part, for an
//   earlier one a piece for each part and each half of its lower half's next
//   split, those whose halves' next splits agree (straight) in one batch,
//   the others (crossed) in the next.  One on a static body is in its moving
//   body's region's wall piece; one on a kinematic body (no region) in a
//   piece of its own.  So no two pieces of a batch hold one moving body, and
//   the order in which a batch's pieces run cannot change a bit of the
//   result.  A piece sweeps its manifolds in the group's order (Bullet's:
//   physics/island_group.h).
// - The wall rows come last in each sweep, so that a sweep ends with every
//   box's wall contacts met: mixed in with the box-box rows, a pile under
//   50 g pushed boxes into the walls (scene 4, 400 boxes: 18 boxes sunk
//   where Bullet's serial order sank none; docs/results/solver_order_error.md).
// - The static walls are never written: all static bodies share Bullet's one
//   fixed solver body, and Bullet's SIMD row functions add (zero) impulses to
//   it, so no row names it; a row against a static body names instead the
//   fixed body's copy of its piece (copy k serves piece k of whichever batch
//   runs), and no two live pieces write one copy.  The copies are fixed
//   bodies as Bullet makes them (initSolverBody(nullptr)) and stay zero, as
//   the shared one would.
// - Kinematic bodies are written by their rows too: they have no region, so
//   their manifolds are in one piece, swept after the splits' batches.
// - Joints (btTypedConstraint rows, none in the scenes) are converted and
//   solved serially in Bullet's order, before the contacts of each sweep.
// - The early stop (m_leastSquaresResidualThreshold) compares, as Bullet's
//   serial solver does, the largest squared residual of the sweep.
//   SOLVER_RANDMIZE_ORDER is not followed: the order is the batches'.
// - The contact rows lie in the row pools in piece order, so that every
//   sweep reads the pools from front to back: scene 4's 3500-box step took
//   0.90x as long on one thread as with the rows in manifold order, to the
//   same bits (docs/results/coloured_solver_rows.csv).  A piece's rows are
//   one range of the pools, swept in one loop that calls Bullet's row
//   function through the pointer its resolve... members call.
// - The solver bodies are numbered region by region, each region's bodies
//   in the group's order, so that a piece's bodies lie together in the body
//   pool and, on two threads, each core's in its own cache lines.  The
//   numbers only name the bodies: numbered in the group's order, the state
//   hash was the same (docs/results/thread_scaling.csv: base_coloured
//   against new_coloured).
// - No allocation per iteration: the per-solve arrays keep their capacity.
// - Shared state outside the bodies and rows: Bullet's split-impulse row
//   function counts its calls in a global int (gNumSplitImpulseRecoveries,
//   read by nothing); with split impulse on (SolverMode::kBullet) the pieces
//   of a batch bump it unsynchronised, as Bullet's own Mt solver does.  No
//   other Bullet call made inside a piece writes anything but the piece's
//   rows, bodies and contact points.
//
// Thread use: solveGroup runs on its caller and on the task system's
// threads, which a crew holds for the call (physics/task_crew.h: the loops
// are opened and joined by atomics, one a batch); one solver serves one
// world.  With two threads, each runs the contiguous half of a batch's
// pieces first: the first split's halves.
#pragma once

#include <BulletDynamics/ConstraintSolver/btSequentialImpulseConstraintSolverMt.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gpu/task_system.h"
#include "physics/step_policy.h"
#include "physics/task_crew.h"

namespace overlap::physics {

// The batches of the last solveGroup call, as the rows used them.
struct ContactBatches {
  struct Manifold {
    int body_a;  // solver body ids, as the manifold's rows name them
    int body_b;
  };
  std::vector<Manifold> manifolds;  // in piece order: piece after piece
  std::vector<int> piece_begin;     // piece p: manifolds [piece_begin[p], piece_begin[p + 1])
  std::vector<int> batch_piece;     // batch b: pieces [batch_piece[b], batch_piece[b + 1])
  int regions = 0;  // the regions made (1 to kRegions); 0: unsplit, one piece in manifold order
  int moving_bodies = 0;    // ids [0, moving_bodies) and [first_kinematic, first_copy)
  int fixed_body = -1;      // Bullet's shared fixed solver body
  int first_kinematic = 0;  // kinematic bodies' ids: [first_kinematic, first_copy)
  int first_copy = 0;       // the pieces' fixed-body copies: [first_copy, first_copy + copies)
  int copies = 0;

  int batches() const { return batch_piece.empty() ? 0 : static_cast<int>(batch_piece.size()) - 1; }
};

// "" when the batches keep the invariants above, else the first breach:
// pieces that do not cover the manifolds in order, two pieces of a batch on
// one moving body, a row naming the shared fixed body or an unknown body, a
// fixed-body copy written from another piece than its own.
std::string batchProblem(const ContactBatches& batches);

class ColouredConstraintSolver final : public btSequentialImpulseConstraintSolverMt {
 public:
  // Halvings of the moving bodies: 16 regions, one a thread of a 16-core
  // host, all splits' pieces two to a thread or more on two cores.
  static constexpr int kRegionLevels = 4;
  static constexpr int kRegions = 1 << kRegionLevels;
  // The fewest moving bodies a region holds: fewer halvings for smaller
  // groups (a 150-box pile in 16 regions of 9 boxes slept later, or not at
  // all, than in fewer).
  static constexpr int kBodiesPerRegion = 200;
  static_assert(kRegionLevels >= 2, "the straight and crossed pieces need two splits");
  static constexpr std::size_t kItemsPerPiece = 256;  // bodies, manifolds, rows: the other loops

  // kNone: one piece in manifold order, Bullet's serial sweep (for tests).
  enum class Split { kRegions, kNone };
  explicit ColouredConstraintSolver(TaskSystem& tasks, Split split = Split::kRegions);

  // The last solveGroup call's batches.
  const ContactBatches& lastBatches() const { return batches_; }
  // Batches made since construction.
  std::int64_t batchesMade() const { return batches_made_; }

  // Bullet's solveGroup, with a crew of the task system's threads held for
  // its parallel loops (physics/task_crew.h).
  btScalar solveGroup(btCollisionObject** bodies, int numBodies, btPersistentManifold** manifolds,
                      int numManifolds, btTypedConstraint** constraints, int numConstraints,
                      const btContactSolverInfo& info, btIDebugDraw* debugDrawer,
                      btDispatcher* dispatcher) override;

 protected:
  btScalar solveGroupCacheFriendlySetup(btCollisionObject** bodies, int numBodies,
                                        btPersistentManifold** manifolds, int numManifolds,
                                        btTypedConstraint** constraints, int numConstraints,
                                        const btContactSolverInfo& info,
                                        btIDebugDraw* debugDrawer) override;
  void convertBodies(btCollisionObject** bodies, int numBodies,
                     const btContactSolverInfo& info) override;
  void convertJoints(btTypedConstraint** constraints, int numConstraints,
                     const btContactSolverInfo& info) override;
  void convertContacts(btPersistentManifold** manifolds, int numManifolds,
                       const btContactSolverInfo& info) override;
  void solveGroupCacheFriendlySplitImpulseIterations(
      btCollisionObject** bodies, int numBodies, btPersistentManifold** manifolds, int numManifolds,
      btTypedConstraint** constraints, int numConstraints, const btContactSolverInfo& info,
      btIDebugDraw* debugDrawer) override;
  btScalar solveSingleIteration(int iteration, btCollisionObject** bodies, int numBodies,
                                btPersistentManifold** manifolds, int numManifolds,
                                btTypedConstraint** constraints, int numConstraints,
                                const btContactSolverInfo& info,
                                btIDebugDraw* debugDrawer) override;
  btScalar solveGroupCacheFriendlyFinish(btCollisionObject** bodies, int numBodies,
                                         const btContactSolverInfo& info) override;

 private:
  // The solver body ids of one manifold's bodies; -1 for one that only the
  // serial pass may convert (a kinematic body, or a moving one outside the
  // group's bodies).
  void collectManifolds(btPersistentManifold** manifolds, std::size_t first, std::size_t end);
  // Collect piece `piece`'s manifolds [first, end) counted by bucket.
  void countPiece(std::size_t piece, std::size_t first, std::size_t end);
  // The solver bodies left for the serial pass and their manifolds' buckets;
  // the batches from the buckets' counts (serial); then each manifold's place
  // and first row (a collect piece at a time, on the crew: each piece starts
  // at its own cursors, so the places are those of one pass in manifold
  // order); the pieces' fixed-body copies.
  void batchManifolds(btPersistentManifold** manifolds, int numManifolds,
                      const btContactSolverInfo& info);
  // Collect piece `piece`'s manifolds [first, end) put in their places.
  void scatterPiece(std::size_t piece, std::size_t first, std::size_t end);
  // The row pools sized for the batches (room to spare, as Bullet's Mt
  // solver keeps, so that a growing pile does not reallocate every substep).
  void sizeRowPools(int contacts, int rolling_rows);
  // The group's bodies split into regions: up to kRegionLevels halvings,
  // while a region keeps kBodiesPerRegion; solver_bodies_ and body_region_
  // for them.  Returns the regions made.
  int splitRegions(btCollisionObject** bodies, int numBodies);
  // Manifold m's bucket (and no rows between two bodies that cannot move),
  // once both its bodies have solver bodies; each manifold writes its own.
  void classify(int m);
  // The bucket of a manifold between solver bodies a and b (below).
  int bucketOf(int a, int b) const;
  // The buckets, one a piece, in sweep order: each region's interior; the
  // manifolds across each split, from the last split to the first; each
  // region's walls.  Across the last split, a bucket for each part it halved;
  // across an earlier one, a bucket for each part it halved and each half of
  // that part's lower half (its next split), the pieces whose two halves' next
  // splits agree first (straight), then those whose do not (crossed); one
  // piece for the manifolds on a body of no region (kinematic).
  static constexpr int acrossFirstBucket(int level, bool crossed) {
    if (level == kRegionLevels - 1) return kRegions;
    return kRegions + (1 << (kRegionLevels - 1)) + (1 << (kRegionLevels + 1)) - (1 << (level + 3)) +
           (crossed ? 2 << level : 0);
  }
  static constexpr int kSerialBucket =
      kRegions + (1 << (kRegionLevels - 1)) + (1 << (kRegionLevels + 1)) - 4;
  static constexpr int kFirstWallBucket = kSerialBucket + 1;
  static constexpr int kBuckets = kFirstWallBucket + kRegions;
  // Runs rows(first, end) on each of batch `batch`'s pieces' contact rows
  // (a piece's rows are one range of the pools), its pieces on the task
  // system; returns the largest of the results.
  template <typename Rows>
  btScalar sweepBatch(int batch, const Rows& rows);
  // sweepBatch over every batch in order.
  template <typename Rows>
  btScalar sweep(const Rows& rows);

  // Each returns the largest squared residual of the rows of contacts
  // [first, end): their contact rows solved by `solve` (Bullet's lower-limit
  // or split-impulse row function), their friction rows.
  btScalar solveContactRows(int first, int end, btSingleConstraintRowSolver solve);
  btScalar solveFrictionRows(int first, int end);
  btScalar solveRollingFrictionRows(int contact);

  TaskSystem& tasks_;
  Split split_;
  std::unique_ptr<TaskGroup> crew_jobs_;       // the crews' helper jobs, late ones included
  TaskCrew* crew_ = nullptr;                   // the running solveGroup call's
  const btContactSolverInfo* info_ = nullptr;  // the running solveGroup call's
  ContactBatches batches_;
  std::vector<int> piece_rows_;  // piece p: contact rows [piece_rows_[p], piece_rows_[p + 1])
  std::vector<int> bucket_;      // per group manifold: its bucket, -1 for none, -2 until classified
  std::vector<int> body_region_;  // per solver body: its region, -1 for none
  // Split: the group's bodies in solver body order, region after region.
  std::vector<btCollisionObject*> solver_bodies_;
  struct RegionKey {
    btVector3 origin;
    std::array<std::int32_t, 3> key;  // origin's coordinates, in IEEE-754's total order
    int body;
  };
  std::vector<RegionKey> region_keys_;  // the moving bodies, as the region split orders them
  std::vector<int> part_begin_;         // the split's parts of region_keys_ at one level
  std::vector<int> part_halves_;        // the next level's
  // Manifolds, contact rows and rolling-friction rows: counts, then the
  // places where the next of them go.
  struct BucketCount {
    int manifolds = 0;
    int rows = 0;
    int rolling_rows = 0;
    void add(const BucketCount& other) {
      manifolds += other.manifolds;
      rows += other.rows;
      rolling_rows += other.rolling_rows;
    }
  };
  std::vector<BucketCount> piece_counts_;   // per collect piece, kBuckets each: its own
  std::vector<BucketCount> bucket_counts_;  // per bucket: the pieces' sum, then its start
  std::vector<int> batch_of_bucket_;        // per bucket: its batch's first bucket
  std::vector<btScalar> piece_residual_;    // per piece of the running sweep
  std::vector<char> piece_unconverted_;     // per collect piece: a body left for the serial pass
  std::int64_t batches_made_ = 0;
};

// The solver `order` names: a ColouredConstraintSolver on `tasks`, or
// Bullet's btSequentialImpulseConstraintSolver.
std::unique_ptr<btConstraintSolver> makeConstraintSolver(SolverOrder order, TaskSystem& tasks);

}  // namespace overlap::physics
