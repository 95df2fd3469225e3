// A broadphase on its own, fed recorded AABBs instead of a simulation.
//
// BroadphaseReplay creates one proxy per object at the first frame's boxes
// (all in the default filter group, so every pair counts); each update()
// after that writes a frame's AABBs into the broadphase, findPairs() lets it
// update its pair cache, and pairs() reads the cache back.
// It is how `overlap pairs` and the broadphase benchmark drive Bullet's
// broadphases and ours through the same btBroadphaseInterface, with the same
// pair cache the simulation uses.
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "physics/world.h"

namespace overlap::physics {

// How many pairs of `wanted` are not in `held`, both sorted: a broadphase's
// missed pairs against the exact ones, or with the arguments swapped its extra ones.
inline std::size_t countMissing(const PairList& wanted, const PairList& held) {
  std::size_t missing = 0;
  auto h = held.begin();
  for (const auto& pair : wanted) {
    h = std::lower_bound(h, held.end(), pair);
    if (h == held.end() || *h != pair) ++missing;
  }
  return missing;
}

class BroadphaseReplay {
 public:
  // `world` bounds every box of the stream (SAP quantizes inside it).
  BroadphaseReplay(std::string_view algorithm, const Aabb& world, int objects);
  ~BroadphaseReplay();
  BroadphaseReplay(const BroadphaseReplay&) = delete;
  BroadphaseReplay& operator=(const BroadphaseReplay&) = delete;

  const std::string& algorithm() const { return algorithm_; }
  const std::string& notice() const { return notice_; }

  // Writes the frame's AABBs (one per object) into the broadphase; the first
  // call creates the proxies there.
  void update(std::span<const Aabb> boxes);
  // Finds the pairs and updates the persistent pair cache.
  void findPairs();
  // The cache's pairs as object indices (a < b), sorted.
  PairList pairs() const;

 private:
  struct Bullet;
  std::string algorithm_;
  std::string notice_;
  std::unique_ptr<Bullet> bullet_;
};

}  // namespace overlap::physics
