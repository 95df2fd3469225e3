#include "physics/broadphase/growing_sweep_and_prune.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace overlap::physics {
namespace {

bool finite(const btVector3& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

}  // namespace

template <typename Sweep>
btBroadphaseProxy* GrowingSweepAndPrune<Sweep>::createProxy(const btVector3& aabbMin,
                                                            const btVector3& aabbMax, int shapeType,
                                                            void* userPtr, int collisionFilterGroup,
                                                            int collisionFilterMask,
                                                            btDispatcher* dispatcher) {
  fit(aabbMin, aabbMax, dispatcher);
  btBroadphaseProxy* proxy = Sweep::createProxy(
      aabbMin, aabbMax, shapeType, userPtr, collisionFilterGroup, collisionFilterMask, dispatcher);
  // Bullet keeps the float box only from setAabb on; a growth needs it.
  proxy->m_aabbMin = aabbMin;
  proxy->m_aabbMax = aabbMax;
  return proxy;
}

template <typename Sweep>
void GrowingSweepAndPrune<Sweep>::setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin,
                                          const btVector3& aabbMax, btDispatcher* dispatcher) {
  fit(aabbMin, aabbMax, dispatcher);
  Sweep::setAabb(proxy, aabbMin, aabbMax, dispatcher);
}

// Grows the bounds around a box that does not fit in them.
template <typename Sweep>
void GrowingSweepAndPrune<Sweep>::fit(const btVector3& aabbMin, const btVector3& aabbMax,
                                      btDispatcher* dispatcher) {
  const btVector3& lo = this->m_worldAabbMin;
  const btVector3& hi = this->m_worldAabbMax;
  if (!finite(aabbMin) || !finite(aabbMax)) return;
  // Strictly inside: a corner on a face quantizes onto Bullet's clamped edge.
  bool inside = true;
  for (int axis = 0; axis < 3; ++axis) {
    inside = inside && aabbMin[axis] > lo[axis] && aabbMax[axis] < hi[axis];
  }
  if (inside) return;
  // Only the faces the box passes move, each by a quarter of the new extent
  // beyond it (room to grow on): the grid stays as fine as the boxes allow.
  btVector3 new_lo = lo, new_hi = hi;
  new_lo.setMin(aabbMin);
  new_hi.setMax(aabbMax);
  const btVector3 extent = new_hi - new_lo;
  const btScalar widest = std::max({extent.x(), extent.y(), extent.z(), btScalar(1e-6)});
  for (int axis = 0; axis < 3; ++axis) {
    const btScalar room = btScalar(0.25) * std::max(extent[axis], widest * btScalar(1e-3));
    if (aabbMin[axis] <= lo[axis]) new_lo[axis] -= room;
    if (aabbMax[axis] >= hi[axis]) new_hi[axis] += room;
  }
  if (!finite(new_hi - new_lo)) return;  // past float range: Bullet clamps, as before
  setBounds(new_lo, new_hi, dispatcher);
  ++growths_;
}

template <typename Sweep>
void GrowingSweepAndPrune<Sweep>::setBounds(const btVector3& lo, const btVector3& hi,
                                            btDispatcher* dispatcher) {
  this->m_worldAabbMin = lo;
  this->m_worldAabbMax = hi;
  const auto sentinel = static_cast<btScalar>(this->m_handleSentinel);
  this->m_quantize = btVector3(sentinel, sentinel, sentinel) / (hi - lo);
  requantize(dispatcher);
}

template <typename Sweep>
void GrowingSweepAndPrune<Sweep>::calculateOverlappingPairs(btDispatcher* dispatcher) {
  const auto count = static_cast<int>(this->m_numHandles);
  btVector3 lo(BT_LARGE_FLOAT, BT_LARGE_FLOAT, BT_LARGE_FLOAT);
  btVector3 hi = -lo;
  btScalar smallest = BT_LARGE_FLOAT;  // the smallest box's widest side, points left out
  const Edge* edges = this->m_pEdges[0];
  for (int e = 1; e <= 2 * count; ++e) {
    if (edges[e].IsMax() != 0) continue;
    const Handle* handle = this->getHandle(edges[e].m_handle);
    if (!finite(handle->m_aabbMin) || !finite(handle->m_aabbMax)) continue;
    lo.setMin(handle->m_aabbMin);
    hi.setMax(handle->m_aabbMax);
    const btVector3 side = handle->m_aabbMax - handle->m_aabbMin;
    const btScalar size = std::max({side.x(), side.y(), side.z()});
    if (size > 0) smallest = std::min(smallest, size);
  }
  if (count > 0 && lo.x() <= hi.x()) {
    const btVector3 extent = hi - lo;
    const btVector3 bounds = this->m_worldAabbMax - this->m_worldAabbMin;
    const btScalar widest = std::max({extent.x(), extent.y(), extent.z(), btScalar(1e-6)});
    bool loose = false;
    for (int axis = 0; axis < 3; ++axis) {
      loose = loose || bounds[axis] > 4 * std::max(extent[axis], widest * btScalar(1e-3));
    }
    // Too coarse for the boxes: as fine as their spread allows first.
    if (loose || coarserThanTheBoxes(smallest)) {
      btVector3 room;
      for (int axis = 0; axis < 3; ++axis) {
        room[axis] = btScalar(0.25) * std::max(extent[axis], widest * btScalar(1e-3));
      }
      setBounds(lo - room, hi + room, dispatcher);
    }
    refuseCoarseGrid(lo, hi, smallest);
  }
  Sweep::calculateOverlappingPairs(dispatcher);
}

template <typename Sweep>
btScalar GrowingSweepAndPrune<Sweep>::gridCell() const {
  btScalar widest = 0;
  for (int axis = 0; axis < 3; ++axis) {
    widest = std::max(widest, btScalar(1) / this->m_quantize[axis]);
  }
  return widest;
}

template <typename Sweep>
btScalar GrowingSweepAndPrune<Sweep>::cell() const {
  btScalar extent = 0;
  for (int axis = 0; axis < 3; ++axis) {
    extent = std::max(extent, this->m_worldAabbMax[axis] - this->m_worldAabbMin[axis]);
  }
  // Bullet quantizes (x - min) * q in floats: far from the bounds' minimum
  // their 24 bits, not the grid's 32, set the cell (sap32 beyond about 10^5
  // boxes' widths).
  return gridCell() + extent * std::numeric_limits<btScalar>::epsilon() / 2;
}

template <typename Sweep>
bool GrowingSweepAndPrune<Sweep>::coarserThanTheBoxes(btScalar smallest) const {
  return smallest < BT_LARGE_FLOAT && cell() * kCellsPerSmallestBox > smallest;
}

template <typename Sweep>
void GrowingSweepAndPrune<Sweep>::refuseCoarseGrid(const btVector3& lo, const btVector3& hi,
                                                   btScalar smallest) const {
  if (!coarserThanTheBoxes(smallest)) return;
  const bool sixteen = std::is_same_v<Sweep, btAxisSweep3>;
  const auto number = [](btScalar value) {
    char text[32];
    std::snprintf(text, sizeof(text), "%.4g", static_cast<double>(value));
    return std::string(text);
  };
  const auto point = [&](const btVector3& v) {
    return "(" + number(v.x()) + ", " + number(v.y()) + ", " + number(v.z()) + ")";
  };
  throw std::invalid_argument(
      std::string("algo ") + (sixteen ? "sap" : "sap32") + ": boxes from " + point(lo) + " to " +
      point(hi) + " leave its " + (sixteen ? "16" : "32") + "-bit grid cells of " + number(cell()) +
      " m" + (cell() > gridCell() ? " (floats' precision at that spread)" : "") +
      ", coarser than 1/" + std::to_string(kCellsPerSmallestBox) + " of the smallest box (" +
      number(smallest) + " m): it would pair boxes that do not touch; " +
      (sixteen ? "use sap32 or an exact one (cpusap)" : "use an exact one (cpusap)"));
}

// Every proxy's box on the new grid, each axis sorted again, and the pair
// cache made the set of pairs whose quantized boxes overlap.
template <typename Sweep>
void GrowingSweepAndPrune<Sweep>::requantize(btDispatcher* dispatcher) {
  const auto count = static_cast<int>(this->m_numHandles);
  if (count == 0) return;
  for (int axis = 0; axis < 3; ++axis) {
    // Edges 1 .. 2n lie between the two sentinels at 0 and 2n + 1.
    Edge* edges = this->m_pEdges[axis];
    for (int e = 1; e <= 2 * count; ++e) {
      Handle* handle = this->getHandle(edges[e].m_handle);
      const bool is_max = edges[e].IsMax() != 0;
      decltype(edges[e].m_pos) q[3];
      this->quantize(q, is_max ? handle->m_aabbMax : handle->m_aabbMin, is_max ? 1 : 0);
      edges[e].m_pos = q[axis];
    }
    std::sort(edges + 1, edges + 2 * count + 1, [](const Edge& a, const Edge& b) {
      return a.m_pos != b.m_pos ? a.m_pos < b.m_pos : a.m_handle < b.m_handle;
    });
    for (int e = 1; e <= 2 * count; ++e) {
      Handle* handle = this->getHandle(edges[e].m_handle);
      (edges[e].IsMax() != 0 ? handle->m_maxEdges : handle->m_minEdges)[axis] =
          static_cast<decltype(edges[e].m_pos)>(e);
    }
  }
  // Pairs that no longer overlap on the new grid leave the cache.
  btOverlappingPairCache* cache = this->m_pairCache;
  std::vector<std::pair<btBroadphaseProxy*, btBroadphaseProxy*>> stale;
  const btBroadphasePairArray& held = cache->getOverlappingPairArray();
  for (int i = 0; i < held.size(); ++i) {
    if (!this->testAabbOverlap(held[i].m_pProxy0, held[i].m_pProxy1)) {
      stale.emplace_back(held[i].m_pProxy0, held[i].m_pProxy1);
    }
  }
  for (const auto& [a, b] : stale) {
    cache->removeOverlappingPair(a, b, dispatcher);
    if (this->m_userPairCallback != nullptr) {
      this->m_userPairCallback->removeOverlappingPair(a, b, dispatcher);
    }
  }
  // Pairs that overlap on it enter (those held already stay as they are):
  // one sweep along x, each box tested on y and z against those open.
  const Edge* edges = this->m_pEdges[0];
  std::vector<Handle*> open;
  for (int e = 1; e <= 2 * count; ++e) {
    Handle* handle = this->getHandle(edges[e].m_handle);
    if (edges[e].IsMax() != 0) {
      std::erase(open, handle);
      continue;
    }
    for (Handle* other : open) {
      if (!this->testOverlap2D(handle, other, 1, 2)) continue;
      cache->addOverlappingPair(handle, other);
      if (this->m_userPairCallback != nullptr) {
        this->m_userPairCallback->addOverlappingPair(handle, other);
      }
    }
    open.push_back(handle);
  }
}

bool isSweepAndPrune(const btBroadphaseInterface& broadphase) {
  return dynamic_cast<const btAxisSweep3Internal<unsigned short>*>(&broadphase) != nullptr ||
         dynamic_cast<const btAxisSweep3Internal<unsigned int>*>(&broadphase) != nullptr;
}

template class GrowingSweepAndPrune<btAxisSweep3>;
template class GrowingSweepAndPrune<bt32BitAxisSweep3>;

}  // namespace overlap::physics
