// Insertion and removal through BroadphaseReplay's presence mask: with a
// share of the boxes destroyed and others created every frame, every
// broadphase's pair cache holds exactly the present boxes' overlapping pairs
// (Bullet's sap, sap32 and bvh at least those: they may keep extra ones).
// The same holds when only the boxes that changed are written (updateChanged).
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "physics/broadphase/broadphase_factory.h"
#include "physics/broadphase_replay.h"

namespace overlap::physics {
namespace {

constexpr int kObjects = 400;
constexpr int kFrames = 12;

Aabb movingBox(int object, int frame) {
  std::mt19937 random(static_cast<unsigned>(object) * 31u + 7u);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  Aabb box{};
  for (int axis = 0; axis < 3; ++axis) {
    const float centre =
        16.0f * unit(random) + 0.3f * static_cast<float>(frame) * (unit(random) - 0.5f);
    const float half = 0.2f + 0.8f * unit(random);
    box.min[axis] = centre - half;
    box.max[axis] = centre + half;
  }
  return box;
}

PairList presentOverlaps(const std::vector<Aabb>& boxes, const std::vector<std::uint8_t>& present) {
  PairList pairs;
  for (int a = 0; a < kObjects; ++a) {
    for (int b = a + 1; b < kObjects; ++b) {
      if (present[a] == 0 || present[b] == 0) continue;
      bool overlap = true;
      for (int axis = 0; axis < 3; ++axis) {
        overlap = overlap && boxes[a].min[axis] <= boxes[b].max[axis] &&
                  boxes[b].min[axis] <= boxes[a].max[axis];
      }
      if (overlap) pairs.push_back(orderedPair(a, b));
    }
  }
  return pairs;
}

// The replay's cache after a frame: every present pair; only those for an
// exact broadphase.
void expectPresentPairs(const BroadphaseReplay& replay, const BroadphaseInfo& info,
                        const std::vector<Aabb>& boxes, const std::vector<std::uint8_t>& present,
                        int frame) {
  const PairList wanted = presentOverlaps(boxes, present);
  const PairList held = replay.pairs();
  EXPECT_EQ(countMissing(wanted, held), 0u) << "frame " << frame;
  if (info.exact) {
    EXPECT_EQ(held, wanted) << "frame " << frame;
  }
}

TEST(BroadphaseChurnTest, EveryBroadphaseKeepsThePresentBoxesPairs) {
  const Aabb world{{-5, -5, -5}, {25, 25, 25}};
  for (const BroadphaseInfo& info : broadphaseCatalogue()) {
    for (const double share : {0.01, 0.1}) {
      SCOPED_TRACE(std::string(info.name) + ", share " + std::to_string(share));
      BroadphaseReplay replay(info.name, world, kObjects);
      std::mt19937 random(42);
      std::vector<std::uint8_t> present(kObjects, 1);
      int created = 0, destroyed = 0;
      for (int frame = 0; frame < kFrames; ++frame) {
        std::vector<Aabb> boxes;
        for (int i = 0; i < kObjects; ++i) boxes.push_back(movingBox(i, frame));
        if (frame > 0) {
          for (int k = 0; k < static_cast<int>(share * kObjects); ++k) {
            std::uint8_t& was = present[random() % kObjects];
            (was != 0 ? destroyed : created) += 1;
            was = was != 0 ? 0 : 1;
          }
        }
        replay.update(boxes, present);
        replay.findPairs();
        expectPresentPairs(replay, info, boxes, present, frame);
      }
      EXPECT_GT(destroyed, 0);
      EXPECT_GT(created, 0);
    }
  }
}

TEST(BroadphaseChurnTest, WritingOnlyTheChangedBoxesKeepsEveryBroadphaseExact) {
  const Aabb world{{-5, -5, -5}, {25, 25, 25}};
  const std::vector<std::uint8_t> everyone(kObjects, 1);
  for (const BroadphaseInfo& info : broadphaseCatalogue()) {
    SCOPED_TRACE(std::string(info.name));
    BroadphaseReplay replay(info.name, world, kObjects);
    std::vector<Aabb> boxes;
    for (int i = 0; i < kObjects; ++i) boxes.push_back(movingBox(i, 0));
    EXPECT_THROW(replay.updateChanged(boxes, {}), std::invalid_argument) << "before the first";
    replay.update(boxes);
    replay.findPairs();
    for (int frame = 1; frame < kFrames; ++frame) {
      // A tenth of the boxes move, a different tenth each frame.
      std::vector<std::uint32_t> changed;
      for (int i = frame % 10; i < kObjects; i += 10) {
        boxes[static_cast<std::size_t>(i)] = movingBox(i, frame);
        changed.push_back(static_cast<std::uint32_t>(i));
      }
      replay.updateChanged(boxes, changed);
      replay.findPairs();
      expectPresentPairs(replay, info, boxes, everyone, frame);
    }
    const std::uint32_t past_the_end[] = {kObjects};
    EXPECT_THROW(replay.updateChanged(boxes, past_the_end), std::invalid_argument);
  }
}

TEST(BroadphaseChurnTest, ACountTheBroadphaseCannotHoldIsRefusedWhole) {
  // btAxisSweep3 numbers its handles in 16 bits: the factory refuses, and the
  // replay's half-built state is let go without touching a broadphase.
  EXPECT_THROW(BroadphaseReplay("sap", Aabb{{0, 0, 0}, {1, 1, 1}}, 40000), std::invalid_argument);
}

}  // namespace
}  // namespace overlap::physics
