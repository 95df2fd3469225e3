// The overlap test's hard cases, for every broadphase, driven the same way
// through BroadphaseReplay: touching faces, edges and corners; boxes one float
// step apart; zero-size and flat boxes; many identical boxes; boxes 10^6 m
// from the origin; long thin boxes crossing many.  Each case runs over several
// frames, so pairs also leave and re-enter the cache.
//
// The catalogue's exact broadphases (physics/broadphase/broadphase_factory.h: bf and
// ours) must match the oracle; the others (sap, sap32 quantized, bvh
// fattened) must miss nothing, and their extra pairs are printed and kept
// within a bound each (maxExtraPercent()).
// So these cases also check the catalogue's word "exact".
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "gpu/pair_finder.h"
#include "physics/broadphase/broadphase_factory.h"
#include "physics/broadphase_replay.h"
#include "tests/hard_cases/hard_case_support.h"
#include "tests/needs_device.h"

namespace overlap::hard_cases {
namespace {

using physics::Aabb;

constexpr float kInf = std::numeric_limits<float>::infinity();

// The next float above (or below) x: one float step.
float stepUp(float x) {
  return std::nextafter(x, kInf);
}
float stepDown(float x) {
  return std::nextafter(x, -kInf);
}

Aabb box(float x0, float y0, float z0, float x1, float y1, float z1) {
  return Aabb{{x0, y0, z0}, {x1, y1, z1}};
}

Aabb translated(Aabb b, float dx, float dy, float dz) {
  const float d[3] = {dx, dy, dz};
  for (int axis = 0; axis < 3; ++axis) {
    b.min[axis] += d[axis];
    b.max[axis] += d[axis];
  }
  return b;
}

struct Frame {
  std::vector<Aabb> boxes;
  std::size_t expected_pairs;  // counted by hand; checks the oracle and the case
};

struct HardCase {
  std::vector<Frame> frames;  // the same object count in every frame
};

// The union of every frame's boxes: what a recorded stream's header holds,
// and the bounds SAP quantizes inside.
Aabb worldOf(const HardCase& hard_case) {
  Aabb world{{kInf, kInf, kInf}, {-kInf, -kInf, -kInf}};
  for (const Frame& frame : hard_case.frames) {
    for (const Aabb& b : frame.boxes) {
      for (int axis = 0; axis < 3; ++axis) {
        world.min[axis] = std::min(world.min[axis], b.min[axis]);
        world.max[axis] = std::max(world.max[axis], b.max[axis]);
      }
    }
  }
  return world;
}

// An s x s x s lattice of cubes starting at `origin`: along each axis cube
// k spans [lo_k, lo_k + edge], and the next starts at its end (`apart` =
// false: the cubes touch face to face, edge to edge and corner to corner)
// or one float step past it.
std::vector<Aabb> lattice(int s, const std::array<float, 3>& origin, float edge, bool apart) {
  std::array<std::vector<float>, 3> lo, hi;
  for (int axis = 0; axis < 3; ++axis) {
    float start = origin[static_cast<std::size_t>(axis)];
    for (int k = 0; k < s; ++k) {
      lo[static_cast<std::size_t>(axis)].push_back(start);
      hi[static_cast<std::size_t>(axis)].push_back(start + edge);
      start = apart ? stepUp(start + edge) : start + edge;
    }
  }
  std::vector<Aabb> cubes;
  for (std::size_t i = 0; i < static_cast<std::size_t>(s); ++i) {
    for (std::size_t j = 0; j < static_cast<std::size_t>(s); ++j) {
      for (std::size_t k = 0; k < static_cast<std::size_t>(s); ++k) {
        cubes.push_back(box(lo[0][i], lo[1][j], lo[2][k], hi[0][i], hi[1][j], hi[2][k]));
      }
    }
  }
  return cubes;
}

// Touching neighbours in a 3 x 3 x 3 lattice: along one axis, 3 cells give 7
// ordered (cell, cell) pairs within one step of each other; 7^3 ordered pairs
// minus the 27 cells with themselves, halved.
constexpr std::size_t kTouchingPairsIn3Cubed = (7 * 7 * 7 - 27) / 2;  // 158

HardCase touchingCase() {
  // Touching, then one step apart everywhere (every pair leaves), then
  // touching again at mixed magnitudes and an edge that is no binary fraction.
  return {{{lattice(3, {0, 0, 0}, 1.0f, false), kTouchingPairsIn3Cubed},
           {lattice(3, {0, 0, 0}, 1.0f, true), 0},
           {lattice(3, {1000.3f, -7.1f, 0.2f}, 0.7f, false), kTouchingPairsIn3Cubed}}};
}

// Two boxes that meet on `axis`: the left one ends at `left_end`, the right
// one begins at `touching_begin` (a pair) or at `apart_begin`, one float step
// further (no pair).
struct Meeting {
  int axis;
  float left_end;
  float touching_begin;
  float apart_begin;
};

// The meeting's two boxes; on the other two axes both span [lane, lane + 1],
// so meetings in different lanes never meet each other.  Nothing is added to
// the meeting coordinates, which would round the step away.
std::vector<Aabb> stageMeeting(const Meeting& m, float lane, bool touch) {
  Aabb left = box(lane, lane, lane, lane + 1, lane + 1, lane + 1), right = left;
  left.min[m.axis] = m.left_end - 1.0f;
  left.max[m.axis] = m.left_end;
  right.min[m.axis] = touch ? m.touching_begin : m.apart_begin;
  right.max[m.axis] = m.touching_begin + 1.0f;
  return {left, right};
}

// Two cubes meeting corner to corner at (c + 1, c + 1, c + 1), or a step
// apart on z while still touching on x and y.
std::vector<Aabb> stageCorner(float c, bool touch) {
  return {box(c, c, c, c + 1, c + 1, c + 1),
          box(c + 1, c + 1, touch ? c + 1 : stepUp(c + 1), c + 2, c + 2, c + 2)};
}

// Meetings on every axis at several magnitudes, at signed zero, across the
// denormals, and at a corner.  Each is staged twice: one copy touches in even
// frames and is a step apart in odd ones, the other copy the reverse, so
// every frame holds one pair per meeting and every pair leaves and returns.
HardCase oneStepApartCase() {
  std::vector<Meeting> meetings;
  for (const float at : {1.0f, 1000.3f, -37.1f, 0.0f}) {
    for (int axis = 0; axis < 3; ++axis) meetings.push_back({axis, at, at, stepUp(at)});
  }
  meetings.push_back({0, -0.0f, 0.0f, stepUp(0.0f)});  // -0 == +0; the step is a denormal
  meetings.push_back({1, stepDown(0.0f), stepDown(0.0f), 0.0f});

  auto stage = [&](bool even) {
    std::vector<Aabb> boxes;
    for (std::size_t m = 0; m < meetings.size(); ++m) {
      const float lane = 10.0f * static_cast<float>(m + 1);
      for (const Aabb& b : stageMeeting(meetings[m], lane, even)) boxes.push_back(b);
      for (const Aabb& b : stageMeeting(meetings[m], lane + 5.0f, !even)) boxes.push_back(b);
    }
    for (const Aabb& b : stageCorner(-5.0f, even)) boxes.push_back(b);
    for (const Aabb& b : stageCorner(5000.0f, !even)) boxes.push_back(b);
    return boxes;
  };
  const std::size_t pairs = meetings.size() + 1;
  return {{{stage(true), pairs}, {stage(false), pairs}, {stage(true), pairs}}};
}

// Points, segments and flat squares meeting boxes and each other, then the
// same a float step apart (always on y or z: the scenarios are spread along
// x, and adding to a coordinate would round its step away).
HardCase zeroSizeCase() {
  const Aabb unit = box(0, 0, 0, 1, 1, 1);
  const std::vector<std::vector<Aabb>> meeting = {
      {box(0, 0, 0, 0, 0, 0), box(0, 0, 0, 0, 0, 0)},        // coincident points
      {unit, box(1, 1, 1, 1, 1, 1)},                         // a point on a corner
      {unit, box(0.5f, 0.5f, 1, 0.5f, 0.5f, 1)},             // a point on a face
      {unit, box(0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f)},       // a point inside
      {unit, box(0, 0, 1, 1, 1, 1)},                         // a flat square on a face
      {box(0, 0, 0, 1, 1, 0), box(1, 0, 0, 2, 1, 0)},        // coplanar squares sharing an edge
      {box(-1, 0.5f, 0.5f, 2, 0.5f, 0.5f), unit},            // a segment through a box
      {box(0, 0, 0, 1, 1, 0), box(0.5f, 0, 0, 0.5f, 1, 0)},  // a segment lying on a square
  };
  const float z0 = stepUp(0.0f), z1 = stepUp(1.0f);
  const std::vector<std::vector<Aabb>> apart = {
      {box(0, 0, 0, 0, 0, 0), box(0, 0, z0, 0, 0, z0)},  // points
      {unit, box(0.5f, 0.5f, z1, 0.5f, 0.5f, z1)},       // a point off a face
      {box(0, 0, 0, 1, 1, 0), box(0, 0, z0, 1, 1, z0)},  // stacked squares
      {box(0, 0, 0, 1, 0, 1), box(-1, stepUp(0.0f), 0.5f, 2, stepUp(0.0f), 0.5f)},  // a segment
  };
  std::vector<Aabb> shapes;
  float place = 0.0f;
  for (const auto* group : {&meeting, &apart}) {
    for (const std::vector<Aabb>& scenario : *group) {
      for (const Aabb& b : scenario) shapes.push_back(translated(b, place, 0, 0));
      place += 10.0f;
    }
  }
  // Then every object shrinks to the point at its min corner: of all the
  // scenarios only the coincident points still meet.
  std::vector<Aabb> corners;
  for (const Aabb& b : shapes) {
    corners.push_back(box(b.min[0], b.min[1], b.min[2], b.min[0], b.min[1], b.min[2]));
  }
  return {{{shapes, meeting.size()}, {corners, 1}, {shapes, meeting.size()}}};
}

HardCase identicalCase() {
  constexpr int kCount = 200;
  constexpr std::size_t kAllPairs = kCount * (kCount - 1) / 2;
  const std::vector<Aabb> boxes(kCount, box(-0.5f, 2.0f, 3.0f, 0.5f, 2.5f, 3.25f));
  const std::vector<Aabb> points(kCount, box(7, 7, 7, 7, 7, 7));
  std::vector<Aabb> halves = boxes;  // every other box moves away along x, in a row
  for (std::size_t i = 1; i < halves.size(); i += 2) {
    halves[i] = translated(halves[i], 10.0f + 2.0f * static_cast<float>(i), 0, 0);
  }
  return {{{boxes, kAllPairs},
           {points, kAllPairs},
           {halves, (kCount / 2) * (kCount / 2 - 1) / 2},
           {boxes, kAllPairs}}};
}

// The touching lattice near (10^6, -10^6, 10^6), where a float step is 1/16
// m, then the same a step apart, and one box at the origin all along, so
// that the world bounds span 2 * 10^6 m.
HardCase farCase() {
  constexpr float kFar = 1.0e6f;
  auto far = [&](bool apart) {
    std::vector<Aabb> boxes = lattice(3, {kFar, -kFar, kFar}, 1.0f, apart);
    boxes.push_back(box(-1, -1, -1, 1, 1, 1));
    return boxes;
  };
  return {
      {{far(false), kTouchingPairsIn3Cubed}, {far(true), 0}, {far(false), kTouchingPairsIn3Cubed}}};
}

// An 8 x 8 row of unit cubes in the xz plane, spaced 2 m, crossed by eight
// thin rods along x and eight along z (each through 8 cubes, and every x rod
// through every z rod): 64 + 64 + 64 pairs.  Then the rods lift by their
// own thickness plus a step, off the cubes but still crossing each other.
HardCase longThinCase() {
  constexpr int kRow = 8;
  constexpr float kThin = 0.01f;
  std::vector<Aabb> cubes, crossing, lifted;
  for (int i = 0; i < kRow; ++i) {
    for (int k = 0; k < kRow; ++k) {
      const float x = 2.0f * static_cast<float>(i), z = 2.0f * static_cast<float>(k);
      cubes.push_back(box(x, 0, z, x + 1, 1, z + 1));
    }
  }
  crossing = cubes;
  lifted = cubes;
  for (int r = 0; r < kRow; ++r) {
    const float at = 2.0f * static_cast<float>(r) + 0.5f;
    crossing.push_back(box(-1, 0.5f, at, 17, 0.5f + kThin, at + kThin));
    crossing.push_back(box(at, 0.5f, -1, at + kThin, 0.5f + kThin, 17));
    lifted.push_back(box(-1, stepUp(1), at, 17, stepUp(1) + kThin, at + kThin));
    lifted.push_back(box(at, stepUp(1), -1, at + kThin, stepUp(1) + kThin, 17));
  }
  return {{{crossing, 3 * kRow * kRow}, {lifted, kRow * kRow}, {crossing, 3 * kRow * kRow}}};
}

// The inexact broadphases (Bullet's) report extra pairs: boxes their
// quantization or margins cannot tell apart.  Over a case's frames, each
// reports at most this many percent of the case's exact pairs.  The bounds
// sit just above the most they reported on any of the cases below: sap 233%
// (737 beside 316, FarFromTheOrigin), sap32 76% (34 beside 45, OneFloatStepApartIsNotAPair), bvh
// 67% (30 beside 45, the same case).
int maxExtraPercent(std::string_view algorithm) {
  if (algorithm == "sap") return 240;
  if (algorithm == "sap32") return 80;
  if (algorithm == "bvh") return 70;
  return -1;  // none: an inexact broadphase without a bound fails the test
}

class PairHardCases : public ::testing::TestWithParam<std::string_view> {
 protected:
  void SetUp() override { OVERLAP_NEEDS_DEVICE_FOR(GetParam()); }

  // Feeds every frame to the broadphase and checks its cache against the oracle.
  void check(const HardCase& hard_case) {
    const std::string algorithm(GetParam());
    const auto objects = static_cast<int>(hard_case.frames.front().boxes.size());
    physics::BroadphaseReplay replay(algorithm, worldOf(hard_case), objects);
    ASSERT_EQ(replay.algorithm(), algorithm) << replay.notice();
    std::size_t extras = 0, exact_pairs = 0;
    for (std::size_t f = 0; f < hard_case.frames.size(); ++f) {
      const Frame& frame = hard_case.frames[f];
      ASSERT_EQ(frame.boxes.size(), static_cast<std::size_t>(objects));
      const PairList expected = oraclePairs(frame.boxes);
      ASSERT_EQ(expected.size(), frame.expected_pairs) << "the oracle disagrees with the case";
      replay.update(frame.boxes);
      replay.findPairs();
      const PairList found = replay.pairs();
      if (isExact(algorithm)) {
        EXPECT_TRUE(samePairs(found, expected)) << algorithm << " frame " << f;
      } else {
        EXPECT_TRUE(missesNoPair(found, expected)) << algorithm << " frame " << f;
        extras += pairsMissingFrom(found, expected).size();
      }
      exact_pairs += expected.size();
    }
    if (!isExact(algorithm)) {
      std::printf("[ extras   ] %s: %zu extra pairs beside %zu exact ones over %zu frames\n",
                  algorithm.c_str(), extras, exact_pairs, hard_case.frames.size());
      const int bound = maxExtraPercent(algorithm);
      ASSERT_GE(bound, 0) << algorithm << " is inexact and has no bound on its extra pairs";
      EXPECT_LE(extras * 100, static_cast<std::size_t>(bound) * exact_pairs)
          << algorithm << ": " << extras << " extra pairs beside " << exact_pairs
          << " exact ones, over its bound of " << bound << "%";
    }
  }
};

TEST_P(PairHardCases, TouchingFacesEdgesAndCorners) {
  check(touchingCase());
}
// Bullet's sweep and prune refuses boxes spread so far that its grid would
// be coarser than them, rather than pair boxes that do not touch: 16-bit
// sap names its grid, sap32 the floats it quantizes in.
void checkOrRefusedBySap(const std::string& algorithm, const std::function<void()>& check_case) {
  if (algorithm != "sap" && algorithm != "sap32") {
    check_case();
    return;
  }
  try {
    check_case();
  } catch (const std::invalid_argument& error) {
    const char* reason = algorithm == "sap" ? "16-bit grid" : "(floats' precision at that spread)";
    EXPECT_NE(std::string(error.what()).find(reason), std::string::npos) << error.what();
  }
}

TEST_P(PairHardCases, OneFloatStepApartIsNotAPair) {
  checkOrRefusedBySap(std::string(GetParam()), [&] { check(oneStepApartCase()); });
}
TEST_P(PairHardCases, ZeroSizeAndFlatBoxes) {
  check(zeroSizeCase());
}
TEST_P(PairHardCases, TwoHundredIdenticalBoxesMakeEveryPair) {
  check(identicalCase());
}
TEST_P(PairHardCases, FarFromTheOrigin) {
  checkOrRefusedBySap(std::string(GetParam()), [&] { check(farCase()); });
}
TEST_P(PairHardCases, LongThinBoxesCrossingMany) {
  check(longThinCase());
}

std::string broadphaseTestName(const ::testing::TestParamInfo<std::string_view>& param_info) {
  std::string name(param_info.param);
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

INSTANTIATE_TEST_SUITE_P(EveryBroadphase, PairHardCases,
                         ::testing::ValuesIn(physics::broadphaseNames().begin(),
                                             physics::broadphaseNames().end()),
                         broadphaseTestName);

}  // namespace
}  // namespace overlap::hard_cases
