// CcdQueryBroadphase: pairs from the wrapped broadphase, queries from the
// shared tree, answered with the wrapped broadphase's own proxies.
#include "physics/broadphase/ccd_query_broadphase.h"

#include <BulletCollision/BroadphaseCollision/btSimpleBroadphase.h>
#include <gtest/gtest.h>

#include <memory>
#include <set>
#include <vector>

#include "physics/world.h"

namespace overlap::physics {
namespace {

struct RayCollector final : btBroadphaseRayCallback {
  bool process(const btBroadphaseProxy* proxy) override {
    seen.insert(proxy);
    return true;
  }
  std::set<const btBroadphaseProxy*> seen;
};

struct AabbCollector final : btBroadphaseAabbCallback {
  bool process(const btBroadphaseProxy* proxy) override {
    seen.insert(proxy);
    return true;
  }
  std::set<const btBroadphaseProxy*> seen;
};

// A ray along +x from the origin, prepared as btCollisionWorld prepares one.
void aimAlongX(btBroadphaseRayCallback& ray, btScalar length) {
  ray.m_rayDirectionInverse.setValue(1, BT_LARGE_FLOAT, BT_LARGE_FLOAT);
  ray.m_signs[0] = ray.m_signs[1] = ray.m_signs[2] = 0;
  ray.m_lambda_max = length;
}

class CcdQueryBroadphaseTest : public ::testing::Test {
 protected:
  // As a world does: every proxy is destroyed before its broadphase (the
  // tree's proxies are freed by destroyProxy, not by the tree).
  void TearDown() override {
    for (btBroadphaseProxy* proxy : proxies_) queries_.destroyProxy(proxy, nullptr);
  }
  btBroadphaseProxy* add(const btVector3& lo, const btVector3& hi) {
    // btSimpleBroadphase pairs only proxies with a client object.
    proxies_.push_back(queries_.createProxy(lo, hi, BOX_SHAPE_PROXYTYPE, &client_, 1, -1, nullptr));
    return proxies_.back();
  }
  void destroy(btBroadphaseProxy* proxy) {
    std::erase(proxies_, proxy);
    queries_.destroyProxy(proxy, nullptr);
  }
  int client_ = 0;
  std::vector<btBroadphaseProxy*> proxies_;
  btSimpleBroadphase* pairs_ = new btSimpleBroadphase(16);
  CcdQueryBroadphase queries_{std::unique_ptr<btBroadphaseInterface>(pairs_)};
};

TEST_F(CcdQueryBroadphaseTest, PairsComeFromTheWrappedBroadphase) {
  add({0, 0, 0}, {1, 1, 1});
  add({0.5f, 0.5f, 0.5f}, {2, 2, 2});
  queries_.calculateOverlappingPairs(nullptr);
  EXPECT_EQ(queries_.getOverlappingPairCache(), pairs_->getOverlappingPairCache());
  EXPECT_EQ(pairs_->getOverlappingPairCache()->getNumOverlappingPairs(), 1);
  EXPECT_EQ(&queries_.pairSearch(), pairs_);
}

TEST_F(CcdQueryBroadphaseTest, RayTestAnswersWithTheWrappedProxiesOnTheRay) {
  btBroadphaseProxy* near = add({2, -0.5f, -0.5f}, {3, 0.5f, 0.5f});
  btBroadphaseProxy* far = add({8, -0.5f, -0.5f}, {9, 0.5f, 0.5f});
  add({2, 3, 3}, {3, 4, 4});  // beside the ray
  RayCollector ray;
  aimAlongX(ray, 10);
  queries_.rayTest({0, 0, 0}, {10, 0, 0}, ray, {0, 0, 0}, {0, 0, 0});
  EXPECT_EQ(ray.seen, (std::set<const btBroadphaseProxy*>{near, far}));
}

TEST_F(CcdQueryBroadphaseTest, AQueryAfterAMoveSeesTheNewBoxes) {
  btBroadphaseProxy* box = add({2, 3, 3}, {3, 4, 4});
  RayCollector ray;
  aimAlongX(ray, 10);
  queries_.rayTest({0, 0, 0}, {10, 0, 0}, ray, {0, 0, 0}, {0, 0, 0});
  EXPECT_TRUE(ray.seen.empty());
  queries_.setAabb(box, {5, -0.5f, -0.5f}, {6, 0.5f, 0.5f}, nullptr);
  queries_.rayTest({0, 0, 0}, {10, 0, 0}, ray, {0, 0, 0}, {0, 0, 0});
  EXPECT_EQ(ray.seen, (std::set<const btBroadphaseProxy*>{box}));
  btVector3 lo;
  btVector3 hi;
  queries_.getAabb(box, lo, hi);
  EXPECT_EQ(lo, btVector3(5, -0.5f, -0.5f));
}

TEST_F(CcdQueryBroadphaseTest, ADestroyedProxyIsNeverAnsweredAndTheOthersStay) {
  btBroadphaseProxy* first = add({0, 0, 0}, {1, 1, 1});
  btBroadphaseProxy* second = add({0.5f, 0, 0}, {1.5f, 1, 1});
  btBroadphaseProxy* third = add({0.2f, 0, 0}, {0.8f, 1, 1});
  queries_.setAabb(third, {0.1f, 0, 0}, {0.9f, 1, 1}, nullptr);  // stale when destroyed
  destroy(first);
  queries_.setAabb(second, {0.6f, 0, 0}, {1.6f, 1, 1}, nullptr);
  EXPECT_EQ(queries_.queryMs(), 0) << "only rayTest and aabbTest are timed, not proxy calls";
  AabbCollector box;
  queries_.aabbTest({0, 0, 0}, {2, 1, 1}, box);
  EXPECT_EQ(box.seen, (std::set<const btBroadphaseProxy*>{second, third}));
}

// In a world the sweeps' time is a stage of its own: scene 4's first fall
// gives CCD bodies, so queries run and are timed; without CCD none run.
TEST(CcdQueryTime, IsTimedApartOnlyWhenCcdRuns) {
  SceneConfig config = SceneConfig::forScene(4);
  config.objects = 200;
  for (const CcdMode ccd : {CcdMode::kAuto, CcdMode::kOff}) {
    WorldOptions options;
    options.algorithm = "bf";
    options.ccd = ccd;
    PhysicsWorld world(config, options);
    double query_ms = 0;
    int ccd_bodies = 0;
    for (int frame = 0; frame < 3; ++frame) {
      const FrameReport report = world.stepFrame();
      query_ms += report.timings.ccd_query_ms;
      ccd_bodies += report.ccd_bodies;
    }
    if (ccd == CcdMode::kAuto) {
      EXPECT_GT(ccd_bodies, 0);
      EXPECT_GT(query_ms, 0);
    } else {
      EXPECT_EQ(query_ms, 0);
    }
  }
}

}  // namespace
}  // namespace overlap::physics
