// Bullet's sweep and prune (btAxisSweep3, bt32BitAxisSweep3) with bounds
// that follow the boxes.
//
// Bullet's sweep and prune quantizes every box inside the world bounds it is
// built with and clamps a box outside them onto their faces, so boxes beyond
// the bounds collapse together and pair falsely (a row of boxes outside
// them pairs each with all the others).  This one grows its bounds before a
// box that does not fit is created or moved: to the union of the old bounds
// and the box, each face the box passed moved on by a quarter of the union's
// extent, so n boxes moving outward cost O(log) growths and the grid stays
// about as fine as the boxes' spread allows.  A growth quantizes every
// proxy's box again, re-sorts each axis and rebuilds the pair cache's
// entries in O(n log n + pairs), keeping the pairs that still overlap
// (their contact manifolds live on).
//
// Invariants: every finite box lies inside the bounds, so the pair cache
// holds every overlapping pair and only the pairs whose quantized boxes
// overlap (a few more, from rounding to the grid); the proxies a caller
// holds never move.  Before each pair search the bounds shrink back around
// the boxes if these span under a quarter of them on some axis (a box that
// flew far and left must not leave the grid coarse), an O(n) look.  A box
// with a non-finite corner grows nothing (Bullet clamps it, as before).
#pragma once

#include <BulletCollision/BroadphaseCollision/btAxisSweep3.h>

namespace overlap::physics {

template <typename Sweep>
class GrowingSweepAndPrune : public Sweep {
 public:
  using Sweep::Sweep;

  btBroadphaseProxy* createProxy(const btVector3& aabbMin, const btVector3& aabbMax, int shapeType,
                                 void* userPtr, int collisionFilterGroup, int collisionFilterMask,
                                 btDispatcher* dispatcher) override;
  void setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin, const btVector3& aabbMax,
               btDispatcher* dispatcher) override;
  // First shrinks the bounds to the boxes when they span under a quarter of
  // them on an axis (one far box gone must not leave the grid coarse).
  void calculateOverlappingPairs(btDispatcher* dispatcher) override;

  // How many times the bounds grew (for tests).
  int growths() const { return growths_; }

 private:
  using Handle = typename Sweep::Handle;
  using Edge = typename Sweep::Edge;
  void fit(const btVector3& aabbMin, const btVector3& aabbMax, btDispatcher* dispatcher);
  void setBounds(const btVector3& lo, const btVector3& hi, btDispatcher* dispatcher);
  void requantize(btDispatcher* dispatcher);
  int growths_ = 0;
};

// True for Bullet's sweep and prune, grown or not: it keeps its proxies in
// one array that its destructor frees whole, so a teardown may skip
// destroying them one by one (which sorts each one's edges to the end of
// every axis, n^2 in all).
bool isSweepAndPrune(const btBroadphaseInterface& broadphase);

using GrowingAxisSweep16 = GrowingSweepAndPrune<btAxisSweep3>;
using GrowingAxisSweep32 = GrowingSweepAndPrune<bt32BitAxisSweep3>;

extern template class GrowingSweepAndPrune<btAxisSweep3>;
extern template class GrowingSweepAndPrune<bt32BitAxisSweep3>;

}  // namespace overlap::physics
