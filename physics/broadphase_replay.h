// A broadphase on its own, fed recorded AABBs instead of a simulation.
//
// BroadphaseReplay creates one proxy per object at the first frame's boxes
// (all in the default filter group, so every pair counts); each update()
// after that writes a frame's AABBs into the broadphase, findPairs() lets it
// update its pair cache, and pairs() reads the cache back.
// It is how `overlap pairs` and the broadphase benchmark drive Bullet's
// broadphases and ours through the same btBroadphaseInterface, with the same
// pair cache the simulation uses.  With a presence mask an update() also
// destroys the proxies of the objects absent this frame and creates those of
// the objects that came back (insertion and removal).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gpu/pair_finder.h"
#include "physics/aabb.h"

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

// Where one findPairs() of one of our broadphases (physics/broadphase/pair_finder_broadphase.h)
// went.
struct ReplayPhases {
  finders::SearchStats search;  // the finder's record of its search
  double cache_update_ms = 0;   // applying the changes to Bullet's pair cache
};

class BroadphaseReplay {
 public:
  // `world` bounds every box of the stream (SAP quantizes inside it); our
  // CPU finders search on `tasks`, which must outlive the replay.
  BroadphaseReplay(std::string_view algorithm, const Aabb& world, int objects,
                   TaskSystem& tasks = defaultTaskSystem());
  ~BroadphaseReplay();
  BroadphaseReplay(const BroadphaseReplay&) = delete;
  BroadphaseReplay& operator=(const BroadphaseReplay&) = delete;

  // What a replay of `algorithm` holds besides its pair cache, at most: the
  // broadphase that runs here (a device name's fallback where there is no
  // device; its catalogue entry's memory), the replay's own per box, and
  // pairs()' copy per pair.  What the memory bounds count before a replay.
  static finders::MemoryCost memoryCost(std::string_view algorithm);

  const std::string& algorithm() const { return algorithm_; }
  const std::string& notice() const { return notice_; }

  // Writes the frame's AABBs (one per object) into the broadphase: only the
  // boxes that changed since the last frame, as a world skips its sleeping
  // bodies (a box whose bytes are unchanged is not written); the first call
  // creates the proxies there.  With `present` (one entry per object),
  // an object whose entry is 0 has no proxy this frame: it is destroyed if it
  // had one, and created again at its box when its entry is 1 again.  A signal
  // (gpu/base/interrupt.h) stops the first call's creation of the proxies,
  // which a sweep and prune does in time n^2, with Interrupted.
  void update(std::span<const Aabb> boxes, std::span<const std::uint8_t> present = {});
  // Writes only the boxes named in `changed` (object indices) and leaves the
  // others as last written, as a world writes only its awake bodies: a
  // caller that already knows what changed (the benchmark, which finds it
  // outside its timing) spares the comparison of every box.  Not the first
  // update.
  void updateChanged(std::span<const Aabb> boxes, std::span<const std::uint32_t> changed);
  // The most bytes the pair cache (with memoryCost()'s bytes per pair and
  // `caller_per_pair` bytes a pair the caller keeps) may hold; findPairs() throws PairMemoryError
  // (physics/broadphase/bulk_pair_cache.h) instead of growing past it.  0: no limit.
  void setPairMemoryLimit(std::uint64_t bytes, std::uint64_t caller_per_pair = 0);
  // Finds the pairs and updates the persistent pair cache.  A signal may cut
  // a finder's search short (bf, cpubf): findPairs then throws Interrupted
  // (gpu/base/interrupt.h) at where(), so no caller compares or prints part
  // of a search as if it were whole.
  void findPairs(const std::function<std::string()>& where = [] { return "a pair search"; });
  // The cache's pairs as object indices (a < b), sorted.
  PairList pairs() const;
  // The last findPairs()'s split, for our broadphases only.
  std::optional<ReplayPhases> lastPhases() const;

 private:
  struct Bullet;
  void updatePresent(std::span<const Aabb> boxes, std::span<const std::uint8_t> present);
  std::string algorithm_;
  std::string notice_;
  std::unique_ptr<Bullet> bullet_;
};

}  // namespace overlap::physics
