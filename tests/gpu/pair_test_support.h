// Test support for the pair finders: an exact brute-force oracle, written
// independently of gpu/pairs/pair_logic.h, and box sets that probe the edges of the
// overlap test (touching faces/edges/corners, one ulp apart, identical,
// degenerate, far from the origin) and move from frame to frame.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <optional>
#include <ostream>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gpu/pair_finder.h"

namespace overlap::finders {

inline void PrintTo(const IndexPair& pair, std::ostream* out) {
  *out << "(" << pair.a << ", " << pair.b << ")";
}

}  // namespace overlap::finders

namespace overlap::finders::testing {

inline bool oracleOverlap(const ObjectBounds& x, const ObjectBounds& y) {
  for (int axis = 0; axis < 3; ++axis) {
    if (!(x.min[axis] <= y.max[axis] && y.min[axis] <= x.max[axis])) return false;
  }
  return (x.group & y.mask) != 0 && (y.group & x.mask) != 0;
}

// Every overlapping pair, sorted by (a, b).
inline std::vector<IndexPair> oraclePairs(std::span<const ObjectBounds> boxes) {
  std::vector<IndexPair> pairs;
  for (std::uint32_t a = 0; a < boxes.size(); ++a) {
    for (std::uint32_t b = a + 1; b < boxes.size(); ++b) {
      if (oracleOverlap(boxes[a], boxes[b])) pairs.push_back({a, b});
    }
  }
  return pairs;
}

inline std::vector<IndexPair> pairsIn(const std::vector<IndexPair>& set,
                                      const std::vector<IndexPair>& minus) {
  std::vector<IndexPair> result;
  std::set_difference(set.begin(), set.end(), minus.begin(), minus.end(),
                      std::back_inserter(result));
  return result;
}

inline ObjectBounds box(float x0, float y0, float z0, float x1, float y1, float z1,
                        std::int32_t group = 1, std::int32_t mask = -1) {
  return ObjectBounds{{x0, y0, z0}, {x1, y1, z1}, group, mask};
}

enum class BoxSet { kRandom, kTouching, kOneUlpApart, kIdentical, kDegenerate, kFarFromOrigin };

inline const BoxSet kAllBoxSets[] = {BoxSet::kRandom,      BoxSet::kTouching,
                                     BoxSet::kOneUlpApart, BoxSet::kIdentical,
                                     BoxSet::kDegenerate,  BoxSet::kFarFromOrigin};

inline std::string boxSetName(BoxSet set) {
  switch (set) {
    case BoxSet::kRandom:
      return "random";
    case BoxSet::kTouching:
      return "touching";
    case BoxSet::kOneUlpApart:
      return "one-ulp-apart";
    case BoxSet::kIdentical:
      return "identical";
    case BoxSet::kDegenerate:
      return "degenerate";
    case BoxSet::kFarFromOrigin:
      return "far-from-origin";
  }
  return "?";
}

// n boxes of the given kind as they are at `frame`; the same arguments give
// the same boxes.  Every kind moves some boxes each frame, so pairs come and go.
inline std::vector<ObjectBounds> makeBoxes(BoxSet set, std::uint32_t n, int frame) {
  std::mt19937 random(1234u + n * 7u + static_cast<unsigned>(set));
  std::vector<ObjectBounds> boxes(n);
  const float side = std::cbrt(static_cast<float>(n)) * 1.5f + 1.0f;
  std::uniform_real_distribution<float> position(0.0f, side);
  std::uniform_real_distribution<float> extent(0.1f, 1.2f);
  std::uniform_real_distribution<float> velocity(-0.4f, 0.4f);
  // Cubes of edge 1 on a lattice of step 1 touch face to face, edge to edge and
  // corner to corner; moves by quarter units keep every coordinate exact.
  const auto lattice = static_cast<std::uint32_t>(std::ceil(std::cbrt(static_cast<float>(n))));
  for (std::uint32_t i = 0; i < n; ++i) {
    ObjectBounds& b = boxes[i];
    const auto cell = [&](std::uint32_t axis_step) {
      return static_cast<float>((i / axis_step) % lattice);
    };
    switch (set) {
      case BoxSet::kRandom:
      case BoxSet::kFarFromOrigin: {
        const float offset = set == BoxSet::kFarFromOrigin ? 1.0e6f : 0.0f;
        for (int axis = 0; axis < 3; ++axis) {
          const float centre = position(random) + velocity(random) * static_cast<float>(frame);
          const float half = extent(random) * 0.5f;
          b.min[axis] = offset + centre - half;
          b.max[axis] = offset + centre + half;
        }
        // A few unused slots and one-way filters among them.
        const auto filter = random() % 16u;
        b.group = filter == 0 ? 0 : (filter == 1 ? 2 : 1);
        b.mask = filter == 2 ? 0 : (filter == 3 ? ~2 : -1);
        break;
      }
      case BoxSet::kTouching: {
        const float shift = static_cast<float>((i + static_cast<std::uint32_t>(frame)) % 3) * 0.25f;
        const float origin[3] = {cell(1) + (i % 5 == 0 ? shift : 0.0f), cell(lattice),
                                 cell(lattice * lattice)};
        for (int axis = 0; axis < 3; ++axis) {
          b.min[axis] = origin[axis];
          b.max[axis] = origin[axis] + 1.0f;
        }
        b.group = 1;
        b.mask = -1;
        break;
      }
      case BoxSet::kOneUlpApart: {
        // Box i + 1 starts exactly at box i's end, or one ulp past it.
        const float start = static_cast<float>(i) * 1.5f;
        const bool apart = (i + static_cast<std::uint32_t>(frame)) % 2 == 0;
        const float end = static_cast<float>(i + 1) * 1.5f;
        b = box(start, 0.0f, 0.0f, apart ? std::nextafter(end, -1.0f) : end, 1.0f, 1.0f);
        if (i % 7 == 3) {  // along y and z too, and against a box far in x
          b.min[1] = std::nextafter(1.0f, 2.0f);
          b.max[1] = 2.0f;
        }
        break;
      }
      case BoxSet::kIdentical: {
        const bool moved_away = frame > 0 && i % static_cast<std::uint32_t>(frame + 1) == 0;
        const float x = moved_away ? 10.0f + static_cast<float>(i) * 3.0f : 0.0f;
        b = box(x, 0.0f, 0.0f, x + 2.0f, 2.0f, 2.0f);
        break;
      }
      case BoxSet::kDegenerate: {
        // Points, segments and flat squares on a lattice of step 1, touching
        // the neighbouring cells' faces; some shrink to points over time.
        const float origin[3] = {cell(1), cell(lattice), cell(lattice * lattice)};
        const auto shape = (i + static_cast<std::uint32_t>(frame)) % 4;
        for (int axis = 0; axis < 3; ++axis) {
          b.min[axis] = origin[axis];
          b.max[axis] = origin[axis] + (shape > static_cast<std::uint32_t>(axis) ? 1.0f : 0.0f);
        }
        b.group = 1;
        b.mask = -1;
        break;
      }
    }
  }
  return boxes;
}

// n boxes of scene 4's three size classes (edges 0.1-0.4, 0.8-1.2 and
// 1.6-4.0, in turn) spread uniformly over [0, extent) on each axis, every box
// moved a little further each frame.
inline std::vector<ObjectBounds> pileOfThreeSizes(std::uint32_t n, const float (&extent)[3],
                                                  int frame) {
  std::mt19937 random(5);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const float shortest[3] = {0.1f, 0.8f, 1.6f};
  const float longest[3] = {0.4f, 1.2f, 4.0f};
  std::vector<ObjectBounds> boxes(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t size = i % 3;
    const float edge = shortest[size] + (longest[size] - shortest[size]) * unit(random);
    for (int axis = 0; axis < 3; ++axis) {
      const float centre = extent[axis] * unit(random) + 0.05f * static_cast<float>(frame);
      boxes[i].min[axis] = centre - 0.5f * edge;
      boxes[i].max[axis] = centre + 0.5f * edge;
    }
    boxes[i].group = 1;
    boxes[i].mask = -1;
  }
  return boxes;
}

// The names of the finders of the product's table (finders::pairFinderTable()),
// for tests parameterized over them; `device` picks the CPU or GPU ones.
inline std::vector<std::string_view> finderNames() {
  std::vector<std::string_view> names;
  for (const PairFinderRow& row : pairFinderTable()) names.push_back(row.name);
  return names;
}
inline std::vector<std::string_view> finderNames(bool device) {
  std::vector<std::string_view> names;
  for (const PairFinderRow& row : pairFinderTable()) {
    if (row.needs_device == device) names.push_back(row.name);
  }
  return names;
}

// Names parameterized tests after their finder (gtest takes no '-').
inline std::string finderTestName(const ::testing::TestParamInfo<std::string_view>& param_info) {
  std::string name(param_info.param);
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

// Equal lists, or a short account of the first difference (the lists can
// hold millions of pairs, too many to print).
inline ::testing::AssertionResult samePairs(std::span<const IndexPair> actual,
                                            std::span<const IndexPair> expected) {
  if (std::equal(actual.begin(), actual.end(), expected.begin(), expected.end())) {
    return ::testing::AssertionSuccess();
  }
  const auto [first_actual, first_expected] =
      std::mismatch(actual.begin(), actual.end(), expected.begin(), expected.end());
  auto failure = ::testing::AssertionFailure();
  failure << actual.size() << " pairs where " << expected.size() << " were expected";
  if (first_actual != actual.end()) {
    failure << "; unexpected " << ::testing::PrintToString(*first_actual);
  }
  if (first_expected != expected.end()) {
    failure << "; expected " << ::testing::PrintToString(*first_expected);
  }
  return failure << " at position " << (first_actual - actual.begin());
}

// Runs one frame of `boxes` through both finders: `finder` must give
// `reference`'s delta.
// With `changed`, `finder` is told which slots changed (launchWithChanges).
inline ::testing::AssertionResult sameDeltaAs(
    PairFinder& finder, PairFinder& reference, std::span<const ObjectBounds> boxes,
    std::optional<std::span<const std::uint32_t>> changed = std::nullopt) {
  if (changed) {
    finder.launchWithChanges(boxes, *changed);
  } else {
    finder.launch(boxes);
  }
  reference.launch(boxes);
  const PairDelta expected = reference.finish();
  const PairDelta actual = finder.finish();
  if (auto added = samePairs(actual.added, expected.added); !added) return added << " (added)";
  if (auto removed = samePairs(actual.removed, expected.removed); !removed) {
    return removed << " (removed)";
  }
  return ::testing::AssertionSuccess();
}

// Runs one frame through `finder` and checks its delta against the oracle;
// `pairs` holds last frame's oracle answer and is updated.
inline void expectFrameMatchesOracle(PairFinder& finder, std::span<const ObjectBounds> boxes,
                                     std::vector<IndexPair>& pairs) {
  finder.launch(boxes);
  const PairDelta delta = finder.finish();
  std::vector<IndexPair> now = oraclePairs(boxes);
  EXPECT_TRUE(samePairs(delta.added, pairsIn(now, pairs))) << "added pairs";
  EXPECT_TRUE(samePairs(delta.removed, pairsIn(pairs, now))) << "removed pairs";
  pairs = std::move(now);
}

}  // namespace overlap::finders::testing
