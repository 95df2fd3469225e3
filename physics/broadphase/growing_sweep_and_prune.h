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
// overlap (boxes within 4 cells, from rounding); the proxies a caller
// holds never move.  Before each pair search the bounds shrink back around
// the boxes if these span under a quarter of them on some axis (a box that
// flew far and left must not leave the grid coarse), an O(n) look.  A box
// with a non-finite corner grows nothing (Bullet clamps it, as before).
//
// A grid cell is at most 1/kCellsPerSmallestBox of the smallest box (its
// widest side; points aside), and so is the precision of the floats Bullet
// quantizes in (the bounds' extent times float epsilon: sap32's binding
// limit, at about 10^5 boxes' widths), so a pair held that does not overlap is two
// boxes within 4 cells of each other on every axis (Bullet rounds each side
// out by up to 2).  Boxes spread so far (one box gone far off) that the
// grid would be coarser make the pair search throw std::invalid_argument
// naming the spread, the cell and the smallest box, instead of pairing
// boxes that do not touch.
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
  // them on an axis (one far box gone must not leave the grid coarse); then
  // throws std::invalid_argument if the grid is coarser than the boxes.
  void calculateOverlappingPairs(btDispatcher* dispatcher) override;

  // The most a grid cell may be, as a share of the smallest box.
  static constexpr int kCellsPerSmallestBox = 64;

  // How many times the bounds grew (for tests).
  int growths() const { return growths_; }

 private:
  using Handle = typename Sweep::Handle;
  using Edge = typename Sweep::Edge;
  void fit(const btVector3& aabbMin, const btVector3& aabbMax, btDispatcher* dispatcher);
  void setBounds(const btVector3& lo, const btVector3& hi, btDispatcher* dispatcher);
  void requantize(btDispatcher* dispatcher);
  btScalar gridCell() const;  // the grid's widest cell, in metres
  btScalar cell() const;      // gridCell(), or the floats' precision where coarser
  bool coarserThanTheBoxes(btScalar smallest) const;
  void refuseCoarseGrid(const btVector3& lo, const btVector3& hi, btScalar smallest) const;
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
