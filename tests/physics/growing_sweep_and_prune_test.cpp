// Bullet's sweep and prune quantizes inside the bounds it is built with; ours
// grows them around boxes outside, so sap and sap32 keep every overlapping
// pair and only a few more, wherever the boxes are: a row of boxes far
// beyond the stated world, one that moves further out, one box thrown far
// and back, and one created through a world's broadphase outside its bounds;
// and a spread the grid cannot hold finely is refused.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "physics/broadphase/broadphase_factory.h"
#include "physics/broadphase_replay.h"
#include "tests/physics/aabb_oracle.h"

namespace overlap::physics {
namespace {

constexpr int kBoxes = 300;

// Boxes of edge 3 in a row along x, 1.5 apart: each overlaps its neighbours
// and touches the next but one, 2n - 3 pairs.
std::vector<Aabb> row(float shift) {
  std::vector<Aabb> boxes(kBoxes);
  for (int i = 0; i < kBoxes; ++i) {
    const float x = shift + 1.5f * static_cast<float>(i);
    boxes[i] = Aabb{{x, 0, 0}, {x + 3, 3, 3}};
  }
  return boxes;
}

void expectFewExtraPairs(const BroadphaseReplay& replay, const std::vector<Aabb>& boxes) {
  const PairList wanted = testing::oraclePairs(boxes);
  const PairList held = replay.pairs();
  ASSERT_EQ(wanted.size(), 2u * kBoxes - 3);
  EXPECT_EQ(countMissing(wanted, held), 0u);
  // The grid's rounding may add a neighbour's neighbour here and there, not
  // the quadratic heap of boxes collapsed onto one face.
  EXPECT_LE(held.size(), wanted.size() + wanted.size() / 10) << replay.algorithm();
}

TEST(GrowingSweepAndPrune, BoxesOutsideTheStatedWorldPairOnlyWithTheirNeighbours) {
  const Aabb stated{{0, 0, 0}, {6, 3, 3}};  // around the first few boxes only
  for (const char* algo : {"sap", "sap32"}) {
    BroadphaseReplay replay(algo, stated, kBoxes);
    const std::vector<Aabb> first = row(0);
    replay.update(first);
    replay.findPairs();
    expectFewExtraPairs(replay, first);
    // The whole row moves far out, then back: the bounds follow.
    for (const float shift : {5000.0f, -20000.0f, 0.0f}) {
      const std::vector<Aabb> moved = row(shift);
      replay.update(moved);
      replay.findPairs();
      expectFewExtraPairs(replay, moved);
    }
  }
}

// One box thrown far makes the grid coarse while it is there; once it is
// back, the bounds shrink to the boxes and the grid is fine again.
TEST(GrowingSweepAndPrune, TheBoundsShrinkBackWhenAFarBoxReturns) {
  const Aabb stated{{0, 0, 0}, {6, 3, 3}};
  for (const char* algo : {"sap", "sap32"}) {
    BroadphaseReplay replay(algo, stated, kBoxes);
    std::vector<Aabb> boxes = row(0);
    replay.update(boxes);
    replay.findPairs();
    // As far as sap's 16-bit grid allows boxes of edge 3 (cells of 3/64 m).
    boxes[0] = Aabb{{1000, 0, 0}, {1003, 3, 3}};
    replay.update(boxes);
    replay.findPairs();
    boxes = row(0);
    replay.update(boxes);
    replay.findPairs();
    expectFewExtraPairs(replay, boxes);
  }
}

// One box far enough off that the grid would turn coarser than the boxes
// (sap: a box 1e6 m off gives cells of 19 m) is refused, naming the spread,
// the cell and the smallest box, where Bullet would pair boxes that do not
// touch; sap32's finer grid holds 1e5 m, on either side, but not 1e6 m,
// where the floats it is quantized in are coarser than its grid.
TEST(GrowingSweepAndPrune, AFarBoxThatWouldMakeTheGridCoarserThanTheBoxesIsRefused) {
  const Aabb stated{{0, 0, 0}, {6, 3, 3}};
  for (const auto& [algo, far, refused] :
       {std::tuple{"sap", 1e6f, true}, std::tuple{"sap", 1e7f, true},
        std::tuple{"sap32", 1e5f, false}, std::tuple{"sap32", -1e5f, false},
        // Past about 10^5 boxes' widths the floats Bullet quantizes in are
        // coarser than the grid (at -10^6, gaps of 1/14 of a box paired).
        std::tuple{"sap32", 1e6f, true}, std::tuple{"sap32", -1e6f, true},
        std::tuple{"sap32", 1e30f, true}}) {
    BroadphaseReplay replay(algo, stated, kBoxes);
    std::vector<Aabb> boxes = row(0);
    replay.update(boxes);
    replay.findPairs();
    boxes[kBoxes - 1] = Aabb{{far, 0, 0}, {far + 3, 3, 3}};
    replay.update(boxes);
    if (!refused) {
      replay.findPairs();
      const PairList wanted = testing::oraclePairs(boxes);
      EXPECT_EQ(countMissing(wanted, replay.pairs()), 0u) << algo;
      EXPECT_LE(replay.pairs().size(), wanted.size() + wanted.size() / 10) << algo << " " << far;
      continue;
    }
    try {
      replay.findPairs();
      ADD_FAILURE() << algo << " paired boxes spread to " << far << " m";
    } catch (const std::invalid_argument& error) {
      const std::string text = error.what();
      EXPECT_NE(text.find(std::string("algo ") + algo + ": boxes from"), std::string::npos) << text;
      EXPECT_NE(text.find("grid cells of"), std::string::npos) << text;
      EXPECT_NE(text.find("smallest box (3 m)"), std::string::npos) << text;
    }
  }
}

TEST(GrowingSweepAndPrune, AProxyOutsideTheBoundsKeepsItsPairsAndGainsNoFalseOnes) {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  for (const char* algo : {"sap", "sap32"}) {
    BroadphaseChoice choice =
        makeWorldBroadphase(algo, btVector3(-1, -1, -1), btVector3(1, 1, 1), 8);
    btBroadphaseInterface& bp = *choice.broadphase;
    int ids[4] = {0, 1, 2, 3};
    const auto make = [&](int i, btVector3 lo, btVector3 hi) {
      return bp.createProxy(lo, hi, BOX_SHAPE_PROXYTYPE, &ids[i], btBroadphaseProxy::DefaultFilter,
                            btBroadphaseProxy::AllFilter, &dispatcher);
    };
    // Two overlapping boxes inside, two apart far outside on +x.
    btBroadphaseProxy* a = make(0, btVector3(0, 0, 0), btVector3(0.5, 0.5, 0.5));
    btBroadphaseProxy* others[3] = {
        make(1, btVector3(0.25, 0.25, 0.25), btVector3(0.75, 0.75, 0.75)),
        make(2, btVector3(100, 0, 0), btVector3(101, 1, 1)),
        make(3, btVector3(200, 0, 0), btVector3(201, 1, 1))};
    bp.calculateOverlappingPairs(&dispatcher);
    EXPECT_EQ(bp.getOverlappingPairCache()->getNumOverlappingPairs(), 1) << algo;
    // Box 0 moves out onto box 3: it leaves box 1 and meets box 3.
    bp.setAabb(a, btVector3(200.5, 0.5, 0.5), btVector3(202, 2, 2), &dispatcher);
    bp.calculateOverlappingPairs(&dispatcher);
    const btBroadphasePairArray& pairs = bp.getOverlappingPairCache()->getOverlappingPairArray();
    ASSERT_EQ(pairs.size(), 1) << algo;
    const int p = *static_cast<int*>(pairs[0].m_pProxy0->m_clientObject);
    const int q = *static_cast<int*>(pairs[0].m_pProxy1->m_clientObject);
    EXPECT_EQ(p + q, 3) << algo;  // boxes 0 and 3
    EXPECT_EQ(p * q, 0) << algo;
    for (btBroadphaseProxy* proxy : {a, others[0], others[1], others[2]}) {
      bp.destroyProxy(proxy, &dispatcher);
    }
  }
}

}  // namespace
}  // namespace overlap::physics
