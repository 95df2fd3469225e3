// Bullet's simulation islands handed to the constraint solver in one call:
// the bodies and contact manifolds that btSimulationIslandManager's
// buildAndProcessIslands passes to btDiscreteDynamicsWorld's island
// callback, island after island, in batches of some hundred rows, gathered
// into one group, so that a step makes one solveGroup call.  Bullet's own
// path sorts the manifolds with a comparison that reads four objects per
// manifold at each step; at 3500 boxes it cost more time than the islands.
//
// Rules, each with its reason:
// - The islands' side effects are Bullet's, call for call: the union-find
//   sorted once (sortIslands permutes its elements, so a second sort would
//   scramble the islands), an island whose bodies all sleep put to sleep,
//   the sleeping bodies of an awake island set to WANTS_DEACTIVATION, and a
//   kinematic body waking what it touches.
// - The manifolds are in Bullet's order: gathered in the dispatcher's order,
//   with Bullet's conditions (contacts, a body awake, a response), and
//   sorted by Bullet's own quickSort (btAlignedObjectArray::quickSort) on
//   Bullet's deterministic key (island, first body's proxy id, second's):
//   the key is read once per manifold and packed into one integer, and the
//   same comparisons on the same sequence give the same permutation, ties
//   included.  Where no two keys tie (CCD's predictive manifolds share
//   their pair's key), the order depends on the pairs alone, not on the
//   dispatcher's manifold array (whose releases swap): every broadphase that
//   finds the same pairs gives the same physics, with either solver.
// - The bodies are in Bullet's order: island after island, each island's
//   in the union-find's order, every body of an island with an awake body.
// - One group solves to the bits of Bullet's batches: no two islands share
//   a moving body, every body of an awake island is converted and written
//   back once either way, no row of one island names another's bodies,
//   and the static bodies' rows read zeros whichever solver body stands for
//   them.  The early stop compares a group's largest residual with
//   m_leastSquaresResidualThreshold; at its default 0 a stop means the
//   rows no longer change anything, so later sweeps are no-ops there too.
//   This holds for Bullet's serial solver and for the coloured one unsplit;
//   split, the coloured solver's regions halve the group's bodies, islands
//   together (physics/coloured_solver.h), so its order is the group's own.
// - Not modelled, so the caller runs Bullet's path: joints
//   (btTypedConstraint, none in the scenes) and unsplit islands.
#pragma once

#include <btBulletDynamicsCommon.h>

#include <cstdint>

namespace overlap::physics {

class IslandGroup {
 public:
  // Whether gather() models `world`'s islands (see the rules above).
  static bool models(btDiscreteDynamicsWorld& world);

  // Bullet's buildIslands and processIslands on `world`, after its
  // calculateSimulationIslands, with the solver's group gathered instead of
  // handed to the island callback.  Call once a substep.
  void gather(btDiscreteDynamicsWorld& world);

  btCollisionObject** bodies() { return bodies_.size() == 0 ? nullptr : &bodies_[0]; }
  int bodyCount() const { return bodies_.size(); }
  btPersistentManifold** manifolds() { return manifolds_.size() == 0 ? nullptr : &manifolds_[0]; }
  int manifoldCount() const { return manifolds_.size(); }

 private:
  // One gathered manifold with Bullet's sort key, read once.
  struct Keyed {
    int island;
    int first_id;   // body 0's proxy id
    int second_id;  // body 1's
    btPersistentManifold* manifold;
  };

  // One manifold's key, its three parts packed into one integer in their order.
  struct Packed {
    std::uint64_t key;
    btPersistentManifold* manifold;
  };

  void wakeAndSleepIslands(btDiscreteDynamicsWorld& world);
  // keyed_ sorted as Bullet's quickSort sorts it, through packed keys, when
  // they fit in 64 bits; false (keyed_ untouched) otherwise.
  bool sortByPackedKeys();
  void gatherManifolds(btDiscreteDynamicsWorld& world);
  void gatherIslands(btDiscreteDynamicsWorld& world);

  btAlignedObjectArray<Keyed> keyed_;
  btAlignedObjectArray<Packed> packed_;
  btAlignedObjectArray<btCollisionObject*> bodies_;
  btAlignedObjectArray<btPersistentManifold*> manifolds_;
};

}  // namespace overlap::physics
