// The exact pair oracle over physics::Aabb, for the physics and hard-case
// tests.  There is one brute-force oracle (tests/gpu/pair_test_support.h,
// written from the definition and independent of every broadphase); this
// hands it the boxes with Bullet's filters: boxes dynamic, the objects from
// `first_static` on static, and two static objects never pair.
#pragma once

#include <btBulletCollisionCommon.h>

#include <span>
#include <vector>

#include "physics/world.h"
#include "tests/gpu/pair_test_support.h"

namespace overlap::physics::testing {

// Every overlapping pair (a, b), a < b, sorted; touching counts.
inline PairList oraclePairs(std::span<const Aabb> boxes, int first_static) {
  std::vector<finders::ObjectBounds> bounds(boxes.size());
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    finders::ObjectBounds& b = bounds[i];
    for (int axis = 0; axis < 3; ++axis) {
      b.min[axis] = boxes[i].min[axis];
      b.max[axis] = boxes[i].max[axis];
    }
    const bool is_static = static_cast<int>(i) >= first_static;
    b.group = is_static ? btBroadphaseProxy::StaticFilter : btBroadphaseProxy::DefaultFilter;
    b.mask = is_static ? btBroadphaseProxy::AllFilter ^ btBroadphaseProxy::StaticFilter
                       : btBroadphaseProxy::AllFilter;
  }
  return finders::testing::oraclePairs(bounds);
}

// Every box dynamic.
inline PairList oraclePairs(std::span<const Aabb> boxes) {
  return oraclePairs(boxes, static_cast<int>(boxes.size()));
}

}  // namespace overlap::physics::testing
