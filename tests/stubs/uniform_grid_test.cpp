#include "audio_ai_stubs/uniform_grid.h"

#include <gtest/gtest.h>

#include <set>
#include <vector>

#include "gpu/base/random.h"

namespace overlap::stubs {
namespace {

TEST(UniformGrid, VisitsEveryPointWithinReachOnce) {
  constexpr float kGridHalfExtent = 10.0f;
  SeededRandom random(3);
  std::vector<Eigen::Vector3f> points(500);
  for (Eigen::Vector3f& point : points) {
    // Some points lie outside the cube, as boxes sunk into a wall do.
    for (int axis = 0; axis < 3; ++axis) {
      point[axis] =
          static_cast<float>(random.uniform(-1.2 * kGridHalfExtent, 1.2 * kGridHalfExtent));
    }
  }
  UniformGrid grid;
  grid.rebuild(points, kGridHalfExtent, 1.5f);
  for (int query = 0; query < 50; ++query) {
    const Eigen::Vector3f centre = points[static_cast<std::size_t>(query * 7)];
    const float reach = static_cast<float>(random.uniform(0.5, 6.0));
    std::multiset<std::uint32_t> visited;
    grid.forEachNear(centre, reach, [&](std::uint32_t i) { visited.insert(i); });
    for (std::uint32_t i = 0; i < points.size(); ++i) {
      const bool within = ((points[i] - centre).array().abs() <= reach).all();
      if (within) {
        EXPECT_EQ(visited.count(i), 1u) << "point " << i << ", query " << query;
      }
      EXPECT_LE(visited.count(i), 1u);
    }
  }
}

TEST(UniformGrid, RejectsANonPositiveCellSize) {
  UniformGrid grid;
  EXPECT_THROW(grid.rebuild({}, 1.0f, 0.0f), std::invalid_argument);
}

}  // namespace
}  // namespace overlap::stubs
