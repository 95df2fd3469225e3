// Test support for the hard cases: the exact pair oracle over physics::Aabb
// (tests/physics/aabb_oracle.h); set comparisons that say what
// differs without printing thousands of pairs; a check that a world's state
// is finite; whether a broadphase of the catalogue is exact.
#pragma once

#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <span>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "physics/broadphase/broadphase_factory.h"
#include "physics/world.h"
#include "tests/physics/aabb_oracle.h"

namespace overlap::hard_cases {

using physics::PairList;
using physics::testing::oraclePairs;

// Whether the catalogue's `algorithm` reports exactly the overlapping pairs.
inline bool isExact(const std::string& algorithm) {
  return physics::broadphaseInfo(algorithm).exact;
}

// The pairs of `set` that are not in `minus`; both sorted.
inline PairList pairsMissingFrom(const PairList& set, const PairList& minus) {
  PairList result;
  std::set_difference(set.begin(), set.end(), minus.begin(), minus.end(),
                      std::back_inserter(result));
  return result;
}

inline std::string describePairs(const PairList& pairs, std::size_t at_most = 5) {
  std::ostringstream text;
  text << pairs.size() << " pair(s)";
  for (std::size_t i = 0; i < std::min(at_most, pairs.size()); ++i) {
    text << (i == 0 ? ": " : ", ") << "(" << pairs[i].a << ", " << pairs[i].b << ")";
  }
  if (pairs.size() > at_most) text << ", ...";
  return text.str();
}

// Equal pair lists, or which pairs are missing and which are extra.
inline ::testing::AssertionResult samePairs(const PairList& actual, const PairList& expected) {
  if (actual == expected) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "missing " << describePairs(pairsMissingFrom(expected, actual)) << "; extra "
         << describePairs(pairsMissingFrom(actual, expected));
}

// Every expected pair is in `actual` (which may hold more).
inline ::testing::AssertionResult missesNoPair(const PairList& actual, const PairList& expected) {
  const PairList missing = pairsMissingFrom(expected, actual);
  if (missing.empty()) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "missing " << describePairs(missing);
}

// Every body still in the world (removed boxes are not) has a finite
// position, linear and angular velocity.
inline ::testing::AssertionResult everyBodyIsFinite(physics::PhysicsWorld& world) {
  const btCollisionObjectArray& objects = world.bulletWorld().getCollisionObjectArray();
  for (int i = 0; i < objects.size(); ++i) {
    const btRigidBody* body = btRigidBody::upcast(objects[i]);
    for (const btVector3& v : {body->getWorldTransform().getOrigin(), body->getLinearVelocity(),
                               body->getAngularVelocity()}) {
      if (!std::isfinite(v.x()) || !std::isfinite(v.y()) || !std::isfinite(v.z())) {
        return ::testing::AssertionFailure() << "body " << body->getUserIndex() << " is not finite";
      }
    }
  }
  return ::testing::AssertionSuccess();
}

}  // namespace overlap::hard_cases
