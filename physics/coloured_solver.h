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
// changes is the order: Bullet's serial solver sweeps the rows in manifold
// order; here each solveGroup call colours its manifolds, and the setup (it
// applies the warm-start impulses) and every iteration run colour after
// colour, the manifolds of one colour in parallel.  Debian's Bullet is not a
// BT_THREADSAFE build, so btParallelFor (and with it Bullet's own Mt
// solver) runs serially; these loops run on the task system instead.
//
// Invariants, each with its reason:
// - The colours depend on the manifolds alone (their order and bodies),
//   never on the thread count: each manifold with a touching point takes,
//   in manifold order, the lowest of kColours colours that neither of its
//   moving bodies holds yet (greedy colouring), first the manifolds between
//   two moving bodies, then those on a static body, in colours after all of
//   theirs.  A manifold that finds none goes to the overflow batch, solved
//   last in each sweep, in manifold order, in one piece.  So no coloured
//   batch holds two constraints on one moving body, the manifolds of a batch
//   touch disjoint bodies, and the order in which a batch's pieces run
//   cannot change a bit of the result.
// - The wall rows come last in each sweep, so that a sweep ends with every
//   box's wall contacts met: mixed in with the box-box colours, a pile under
//   50 g pushed boxes into the walls (scene 4, 400 boxes: 18 boxes sunk
//   where Bullet's serial order sank none; docs/results/solver_order_error.md).
// - The static walls are never written: all static bodies share Bullet's one
//   fixed solver body, and Bullet's SIMD row functions add (zero) impulses to
//   it, so no row names it; a row against a static body names instead the
//   fixed body's copy of its piece (pieces of kManifoldsPerPiece manifolds of
//   a batch; copy k serves piece k of whichever batch runs), and no two live
//   pieces write one copy.  The copies are fixed bodies as Bullet makes them
//   (initSolverBody(nullptr)) and stay zero, as the shared one would.
// - Kinematic bodies are coloured like moving ones (their solver bodies are
//   written too).
// - Joints (btTypedConstraint rows, none in the scenes) are converted and
//   solved serially in Bullet's order, before the contacts of each sweep.
// - The early stop (m_leastSquaresResidualThreshold) compares, as Bullet's
//   serial solver does, the largest squared residual of the sweep.
//   SOLVER_RANDMIZE_ORDER is not followed: the order is the colours'.
// - The contact rows lie in the row pools in batch order (a batch's
//   manifolds in manifold order), so that every sweep reads the pools from
//   front to back: scene 4's 3500-box step took 0.90x as long on one
//   thread as with the rows in manifold order, to the same bits
//   (docs/results/coloured_solver_rows.csv).
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
// are opened and joined by atomics, a hundred a solve); one solver serves
// one world.
#pragma once

#include <BulletDynamics/ConstraintSolver/btSequentialImpulseConstraintSolverMt.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gpu/task_system.h"
#include "physics/step_policy.h"
#include "physics/task_crew.h"

namespace overlap::physics {

// The coloured batches of the last solveGroup call, as the rows used them.
struct ContactColouring {
  struct Manifold {
    int body_a;  // solver body ids, as the manifold's rows name them
    int body_b;
  };
  std::vector<Manifold> manifolds;  // in batch order: batch after batch
  std::vector<int> batch_begin;     // batch b: manifolds [batch_begin[b], batch_begin[b + 1])
  bool overflow = false;            // the last batch is the overflow batch (one piece)
  int manifolds_per_piece = 0;      // a coloured batch's pieces, from its first manifold
  int moving_bodies = 0;            // ids [0, moving_bodies) and [first_kinematic, first_copy)
  int fixed_body = -1;              // Bullet's shared fixed solver body
  int first_kinematic = 0;          // kinematic bodies' ids: [first_kinematic, first_copy)
  int first_copy = 0;  // the pieces' fixed-body copies: [first_copy, first_copy + copies)
  int copies = 0;

  int batches() const { return batch_begin.empty() ? 0 : static_cast<int>(batch_begin.size()) - 1; }
};

// "" when the colouring keeps the invariants above, else the first breach:
// a coloured batch with two manifolds on one moving body, a row naming the
// shared fixed body, a fixed-body copy written from two pieces of a batch, an
// overflow batch of more than one piece.
std::string colouringProblem(const ContactColouring& colouring);

class ColouredConstraintSolver final : public btSequentialImpulseConstraintSolverMt {
 public:
  static constexpr int kColours = 64;                 // one bit of a body's mask each
  static constexpr int kManifoldsPerPiece = 32;       // a coloured batch's pieces
  static constexpr std::size_t kItemsPerPiece = 256;  // bodies, manifolds, rows: the other loops

  // `colours`: at most kColours; with 0 every manifold is in the overflow
  // batch, and the sweep is Bullet's serial one, in manifold order.
  explicit ColouredConstraintSolver(TaskSystem& tasks, int colours = kColours);

  // The last solveGroup call's batches.
  const ContactColouring& lastColouring() const { return colouring_; }
  // Coloured batches (the overflow batch included) made since construction.
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
  // The serial pass: each manifold's first row and colour, then the batches
  // and the pieces' fixed-body copies.
  void colourManifolds(btPersistentManifold** manifolds, int numManifolds,
                       const btContactSolverInfo& info);
  // The row pools sized for the colouring (room to spare, as Bullet's Mt
  // solver keeps, so that a growing pile does not reallocate every substep).
  void sizeRowPools(int contacts, int rolling_rows);
  // Runs row(contact) for every row of batch `batch`'s manifolds, its pieces
  // on the task system; returns the largest of row's results.
  template <typename Row>
  btScalar sweepBatch(int batch, const Row& row);
  // sweepBatch over every batch in order.
  template <typename Row>
  btScalar sweep(const Row& row);

  btScalar solveContactRow(int contact);
  btScalar solveFrictionRows(int contact);
  btScalar solveRollingFrictionRows(int contact);

  TaskSystem& tasks_;
  int colours_;
  std::unique_ptr<TaskGroup> crew_jobs_;       // the crews' helper jobs, late ones included
  TaskCrew* crew_ = nullptr;                   // the running solveGroup call's
  const btContactSolverInfo* info_ = nullptr;  // the running solveGroup call's
  ContactColouring colouring_;
  struct RowRange {
    int first;  // the manifold's first contact row
    int rows;
  };
  std::vector<RowRange> rows_;               // batch order: each manifold's contact rows
  std::vector<int> colour_;                  // per group manifold: its batch, -1 for none
  std::vector<std::uint64_t> body_colours_;  // per solver body: the colours it holds
  std::vector<int> batch_fill_;              // per colour: its count, then the scatter cursor
  std::vector<int> colour_rows_;             // per colour: its contact rows, then their cursor
  std::vector<int> colour_rolling_rows_;     // per colour: its rolling-friction rows, likewise
  std::vector<btScalar> piece_residual_;     // per piece of the running sweep
  std::vector<char> piece_unconverted_;      // per collect piece: a body left for the serial pass
  std::int64_t batches_made_ = 0;
};

// The solver `order` names: a ColouredConstraintSolver on `tasks`, or
// Bullet's btSequentialImpulseConstraintSolver.
std::unique_ptr<btConstraintSolver> makeConstraintSolver(SolverOrder order, TaskSystem& tasks);

}  // namespace overlap::physics
