// Broadphases by the names the paper and the CLI use.
//
//   bf           btSimpleBroadphase     (the paper's BF)
//   sap          btAxisSweep3           (SAP; 16-bit quantized, < 32767 objects)
//   sap32        bt32BitAxisSweep3
//   bvh          btDbvtBroadphase       (BVH)
//   cpubf        our brute force on CPU threads (gpubf's twin, the reference)
//   cpusap       our sort-and-sweep on CPU threads (AVX2), exact
//   gpubf        our CUDA brute force (bit-packed, changes compacted on the GPU)
//   gpubf-paper  the paper's CUDA brute force, reproduced as published
//
// A GPU name without a CUDA device falls back to cpusap, the fastest exact
// CPU finder; the returned notice says so in one line, and `name` is what
// actually runs.
#pragma once

#include <btBulletCollisionCommon.h>

#include <memory>
#include <span>
#include <string>
#include <string_view>

namespace overlap::physics {

struct BroadphaseChoice {
  std::unique_ptr<btBroadphaseInterface> broadphase;
  std::string name;    // the algorithm that runs
  std::string notice;  // empty, or why it is not the one asked for
};

std::span<const std::string_view> broadphaseNames();

// `world_min`/`world_max` bound where objects may go (SAP quantizes inside
// them); `max_objects` is the most proxies the run will create.  Throws
// std::invalid_argument for an unknown name or a count the algorithm can't hold.
BroadphaseChoice makeBroadphase(std::string_view name, const btVector3& world_min,
                                const btVector3& world_max, int max_objects);

}  // namespace overlap::physics
