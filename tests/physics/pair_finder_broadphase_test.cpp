// PairFinderBroadphase as Bullet uses it: the pair cache mirrors the oracle
// while proxies move, come and go (also between launch and finish); a pair
// that stays keeps its cache entry and narrowphase state; unusable AABBs and
// the queries behave.  Runs for every finder; GPU ones skip without a device.
#include "physics/broadphase/pair_finder_broadphase.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "tests/gpu/pair_test_support.h"

namespace overlap::physics {
namespace {

using finders::IndexPair;
using finders::ObjectBounds;

constexpr int kDefault = btBroadphaseProxy::DefaultFilter;
constexpr int kAll = btBroadphaseProxy::AllFilter;
constexpr int kStatic = btBroadphaseProxy::StaticFilter;

// Checks, through the cache's ghost callback, that every pair the cache adds
// is new and every pair it removes exists: additions and removals balance.
class PairLedger : public btOverlappingPairCallback {
 public:
  btBroadphasePair* addOverlappingPair(btBroadphaseProxy* p0, btBroadphaseProxy* p1) override {
    EXPECT_TRUE(pairs_.insert(key(p0, p1)).second) << "pair added twice";
    return nullptr;
  }
  void* removeOverlappingPair(btBroadphaseProxy* p0, btBroadphaseProxy* p1,
                              btDispatcher* /*dispatcher*/) override {
    EXPECT_EQ(pairs_.erase(key(p0, p1)), 1u) << "removed a pair that was not there";
    return nullptr;
  }
  void removeOverlappingPairsContainingProxy(btBroadphaseProxy* /*proxy*/,
                                             btDispatcher* /*dispatcher*/) override {}
  std::size_t size() const { return pairs_.size(); }

 private:
  static std::pair<int, int> key(const btBroadphaseProxy* p0, const btBroadphaseProxy* p1) {
    return std::minmax(p0->m_uniqueId, p1->m_uniqueId);
  }
  std::set<std::pair<int, int>> pairs_;
};

class PairFinderBroadphaseTest : public ::testing::TestWithParam<std::string_view> {
 protected:
  void SetUp() override {
    std::string why;
    if (finders::testing::isGpuFinder(GetParam()) && !finders::cudaDeviceAvailable(&why)) {
      GTEST_SKIP() << "no CUDA device: " << why;
    }
    broadphase_ = std::make_unique<PairFinderBroadphase>(finders::makePairFinder(GetParam()));
    broadphase_->getOverlappingPairCache()->setInternalGhostPairCallback(&ledger_);
  }

  btBroadphaseProxy* create(const ObjectBounds& bounds, int group = kDefault, int mask = kAll) {
    return broadphase_->createProxy(minOf(bounds), maxOf(bounds), BOX_SHAPE_PROXYTYPE, nullptr,
                                    group, mask, &dispatcher_);
  }
  static btVector3 minOf(const ObjectBounds& b) { return {b.min[0], b.min[1], b.min[2]}; }
  static btVector3 maxOf(const ObjectBounds& b) { return {b.max[0], b.max[1], b.max[2]}; }

  // The cache's pairs as sorted (smaller id, larger id), each checked unique.
  std::vector<IndexPair> cachedPairs() {
    btOverlappingPairCache* cache = broadphase_->getOverlappingPairCache();
    std::vector<IndexPair> pairs;
    for (int i = 0; i < cache->getNumOverlappingPairs(); ++i) {
      const btBroadphasePair& pair = cache->getOverlappingPairArray()[i];
      const auto [a, b] = std::minmax(pair.m_pProxy0->m_uniqueId, pair.m_pProxy1->m_uniqueId);
      pairs.push_back({static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b)});
    }
    std::sort(pairs.begin(), pairs.end());
    EXPECT_EQ(std::adjacent_find(pairs.begin(), pairs.end()), pairs.end()) << "duplicate pair";
    EXPECT_EQ(pairs.size(), ledger_.size()) << "additions and removals do not balance";
    return pairs;
  }

  // The oracle over the live proxies, by m_uniqueId.
  static std::vector<IndexPair> expectedPairs(const std::vector<btBroadphaseProxy*>& live) {
    int slots = 0;
    for (const btBroadphaseProxy* proxy : live) slots = std::max(slots, proxy->m_uniqueId + 1);
    std::vector<ObjectBounds> bounds(static_cast<std::size_t>(slots), ObjectBounds{});
    for (const btBroadphaseProxy* proxy : live) {
      ObjectBounds& entry = bounds[static_cast<std::size_t>(proxy->m_uniqueId)];
      for (int axis = 0; axis < 3; ++axis) {
        entry.min[axis] = proxy->m_aabbMin[axis];
        entry.max[axis] = proxy->m_aabbMax[axis];
      }
      entry.group = proxy->m_collisionFilterGroup;
      entry.mask = proxy->m_collisionFilterMask;
    }
    return finders::testing::oraclePairs(bounds);
  }

  btDefaultCollisionConfiguration configuration_;
  btCollisionDispatcher dispatcher_{&configuration_};
  PairLedger ledger_;
  std::unique_ptr<PairFinderBroadphase> broadphase_;
};

TEST_P(PairFinderBroadphaseTest, CacheMatchesOracleWhileObjectsMove) {
  std::vector<btBroadphaseProxy*> live;
  for (const ObjectBounds& b :
       finders::testing::makeBoxes(finders::testing::BoxSet::kRandom, 400, 0)) {
    live.push_back(create(b, b.group, b.mask));
  }
  for (int frame = 1; frame < 6; ++frame) {
    const auto moved = finders::testing::makeBoxes(finders::testing::BoxSet::kRandom, 400, frame);
    for (std::size_t i = 0; i < live.size(); ++i) {
      broadphase_->setAabb(live[i], minOf(moved[i]), maxOf(moved[i]), &dispatcher_);
    }
    broadphase_->calculateOverlappingPairs(&dispatcher_);
    EXPECT_TRUE(finders::testing::samePairs(cachedPairs(), expectedPairs(live)))
        << "frame " << frame;
  }
}

TEST_P(PairFinderBroadphaseTest, ProxiesComeAndGoBetweenSearches) {
  std::mt19937 random(7);
  std::uniform_real_distribution<float> position(0.0f, 12.0f);
  const auto randomBox = [&] {
    const float x = position(random), y = position(random), z = position(random);
    return finders::testing::box(x, y, z, x + 1.5f, y + 1.5f, z + 1.5f);
  };
  std::vector<btBroadphaseProxy*> live;
  const auto churn = [&] {
    for (int i = 0; i < 15; ++i) live.push_back(create(randomBox()));
    for (int i = 0; i < 10 && !live.empty(); ++i) {
      const std::size_t victim = random() % live.size();
      broadphase_->destroyProxy(live[victim], &dispatcher_);
      live.erase(live.begin() + static_cast<std::ptrdiff_t>(victim));
    }
    for (btBroadphaseProxy* proxy : live) {
      const ObjectBounds b = randomBox();
      broadphase_->setAabb(proxy, minOf(b), maxOf(b), &dispatcher_);
    }
  };
  for (int frame = 0; frame < 30; ++frame) {
    churn();
    broadphase_->calculateOverlappingPairs(&dispatcher_);
    churn();  // destroyed slots may be taken again only after a search
    std::set<int> ids;
    for (const btBroadphaseProxy* proxy : live) {
      EXPECT_TRUE(ids.insert(proxy->m_uniqueId).second) << "two live proxies share an id";
    }
    for (const IndexPair& pair : cachedPairs()) {
      EXPECT_TRUE(ids.count(static_cast<int>(pair.a)) && ids.count(static_cast<int>(pair.b)))
          << "a cached pair names a destroyed proxy";
    }
    broadphase_->calculateOverlappingPairs(&dispatcher_);
    EXPECT_TRUE(finders::testing::samePairs(cachedPairs(), expectedPairs(live)))
        << "frame " << frame;
  }
}

TEST_P(PairFinderBroadphaseTest, DestroyedSlotIsReusedOnlyAfterTheNextSearch) {
  const ObjectBounds unit = finders::testing::box(0, 0, 0, 1, 1, 1);
  btBroadphaseProxy* keep = create(unit);
  btBroadphaseProxy* gone = create(unit);
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  const int gone_id = gone->m_uniqueId;
  broadphase_->destroyProxy(gone, &dispatcher_);
  EXPECT_EQ(broadphase_->getOverlappingPairCache()->getNumOverlappingPairs(), 0);
  EXPECT_NE(create(unit)->m_uniqueId, gone_id);
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  // The finder saw the slot unused: a new proxy there gets its pairs anew.
  btBroadphaseProxy* reused = create(unit);
  EXPECT_EQ(reused->m_uniqueId, gone_id);
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  EXPECT_NE(broadphase_->getOverlappingPairCache()->findPair(keep, reused), nullptr);
  EXPECT_EQ(cachedPairs().size(), 3u);  // three overlapping unit boxes
}

TEST_P(PairFinderBroadphaseTest, StayingPairKeepsItsCacheEntry) {
  btBroadphaseProxy* a = create(finders::testing::box(0, 0, 0, 1, 1, 1));
  btBroadphaseProxy* b = create(finders::testing::box(0.5f, 0, 0, 1.5f, 1, 1));
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  btBroadphasePair* pair = broadphase_->getOverlappingPairCache()->findPair(a, b);
  ASSERT_NE(pair, nullptr);
  int marker = 0;
  pair->m_internalInfo1 = &marker;
  broadphase_->setAabb(b, btVector3(0.9f, 0, 0), btVector3(1.9f, 1, 1), &dispatcher_);
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  pair = broadphase_->getOverlappingPairCache()->findPair(a, b);
  ASSERT_NE(pair, nullptr);
  EXPECT_EQ(pair->m_internalInfo1, &marker);
  broadphase_->setAabb(b, btVector3(3, 0, 0), btVector3(4, 1, 1), &dispatcher_);
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  EXPECT_EQ(broadphase_->getOverlappingPairCache()->findPair(a, b), nullptr);
}

TEST_P(PairFinderBroadphaseTest, CollisionWorldKeepsNarrowphaseStateOfStayingPairs) {
  btCollisionWorld world(&dispatcher_, broadphase_.get(), &configuration_);
  btBoxShape shape(btVector3(0.5f, 0.5f, 0.5f));
  btCollisionObject first;
  btCollisionObject second;
  first.setCollisionShape(&shape);
  second.setCollisionShape(&shape);
  second.getWorldTransform().setOrigin(btVector3(0.8f, 0, 0));
  world.addCollisionObject(&first);
  world.addCollisionObject(&second);
  world.performDiscreteCollisionDetection();
  btBroadphasePair* pair = broadphase_->getOverlappingPairCache()->findPair(
      first.getBroadphaseHandle(), second.getBroadphaseHandle());
  ASSERT_NE(pair, nullptr);
  ASSERT_NE(pair->m_algorithm, nullptr);
  btCollisionAlgorithm* const algorithm = pair->m_algorithm;
  EXPECT_EQ(dispatcher_.getNumManifolds(), 1);

  second.getWorldTransform().setOrigin(btVector3(0.9f, 0, 0));
  world.performDiscreteCollisionDetection();
  pair = broadphase_->getOverlappingPairCache()->findPair(first.getBroadphaseHandle(),
                                                          second.getBroadphaseHandle());
  ASSERT_NE(pair, nullptr);
  EXPECT_EQ(pair->m_algorithm, algorithm);

  second.getWorldTransform().setOrigin(btVector3(5, 0, 0));
  world.performDiscreteCollisionDetection();
  EXPECT_EQ(broadphase_->getOverlappingPairCache()->getNumOverlappingPairs(), 0);
  EXPECT_EQ(dispatcher_.getNumManifolds(), 0);  // the algorithm went with its pair
  world.removeCollisionObject(&second);
  world.removeCollisionObject(&first);
}

TEST_P(PairFinderBroadphaseTest, StaticObjectsPairOnlyWithDynamicOnes) {
  const ObjectBounds unit = finders::testing::box(0, 0, 0, 1, 1, 1);
  btBroadphaseProxy* floor = create(unit, kStatic, kAll ^ kStatic);
  btBroadphaseProxy* wall = create(unit, kStatic, kAll ^ kStatic);
  btBroadphaseProxy* body = create(unit);
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  btOverlappingPairCache* cache = broadphase_->getOverlappingPairCache();
  EXPECT_EQ(cache->findPair(floor, wall), nullptr);
  EXPECT_NE(cache->findPair(floor, body), nullptr);
  EXPECT_NE(cache->findPair(wall, body), nullptr);
}

TEST_P(PairFinderBroadphaseTest, UnusableAabbLeavesTheSearchWithOneMessage) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  btBroadphaseProxy* a = create(finders::testing::box(0, 0, 0, 1, 1, 1));
  btBroadphaseProxy* b = create(finders::testing::box(0, 0, 0, 1, 1, 1));
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  ASSERT_EQ(cachedPairs().size(), 1u);

  ::testing::internal::CaptureStderr();
  broadphase_->setAabb(b, btVector3(nan, 0, 0), btVector3(1, 1, 1), &dispatcher_);
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  broadphase_->setAabb(b, btVector3(0, 0, 0), btVector3(1, nan, 1), &dispatcher_);
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  const std::string messages = ::testing::internal::GetCapturedStderr();
  EXPECT_TRUE(cachedPairs().empty());
  EXPECT_NE(messages.find("object " + std::to_string(b->m_uniqueId)), std::string::npos)
      << messages;
  EXPECT_EQ(std::count(messages.begin(), messages.end(), '\n'), 1) << messages;

  broadphase_->setAabb(b, btVector3(0, 0, 0), btVector3(1, 1, 1), &dispatcher_);
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  EXPECT_NE(broadphase_->getOverlappingPairCache()->findPair(a, b), nullptr);

  ::testing::internal::CaptureStderr();
  broadphase_->setAabb(a, btVector3(1, 0, 0), btVector3(0, 1, 1), &dispatcher_);  // inverted
  create(finders::testing::box(0, 0, 0, 1, 1, -std::numeric_limits<float>::infinity()));
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  const std::string more = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(std::count(more.begin(), more.end(), '\n'), 2) << more;
  EXPECT_TRUE(cachedPairs().empty());
}

// Collects what a query reports, as m_uniqueIds.
struct Collector : btBroadphaseRayCallback {
  bool process(const btBroadphaseProxy* proxy) override {
    ids.insert(proxy->m_uniqueId);
    return true;
  }
  std::set<int> ids;
};

TEST_P(PairFinderBroadphaseTest, RayTestVisitsTheBoxesOnTheRay) {
  const int on_ray = create(finders::testing::box(2, -0.5f, -0.5f, 3, 0.5f, 0.5f))->m_uniqueId;
  const int far_on_ray = create(finders::testing::box(8, -0.5f, -0.5f, 9, 0.5f, 0.5f))->m_uniqueId;
  create(finders::testing::box(2, 3, 3, 3, 4, 4));  // beside the ray
  const btVector3 from(0, 0, 0);
  const btVector3 to(10, 0, 0);
  Collector collector;
  // As btCollisionWorld's btSingleRayCallback prepares it.
  const btVector3 direction = (to - from).normalized();
  collector.m_rayDirectionInverse.setValue(direction[0] == 0 ? BT_LARGE_FLOAT : 1 / direction[0],
                                           direction[1] == 0 ? BT_LARGE_FLOAT : 1 / direction[1],
                                           direction[2] == 0 ? BT_LARGE_FLOAT : 1 / direction[2]);
  for (int axis = 0; axis < 3; ++axis) {
    collector.m_signs[axis] = collector.m_rayDirectionInverse[axis] < 0.0f;
  }
  collector.m_lambda_max = direction.dot(to - from);
  broadphase_->rayTest(from, to, collector);
  EXPECT_EQ(collector.ids, (std::set<int>{on_ray, far_on_ray}));

  collector.ids.clear();
  collector.m_lambda_max = 5;  // a hit found at 5 hides what lies beyond
  broadphase_->rayTest(from, to, collector);
  EXPECT_EQ(collector.ids, (std::set<int>{on_ray}));
}

TEST_P(PairFinderBroadphaseTest, AabbTestAndBroadphaseAabb) {
  btVector3 lo;
  btVector3 hi;
  broadphase_->getBroadphaseAabb(lo, hi);
  EXPECT_EQ(lo, btVector3(0, 0, 0));
  EXPECT_EQ(hi, btVector3(0, 0, 0));
  const int touching = create(finders::testing::box(1, 1, 1, 2, 2, 2))->m_uniqueId;
  create(finders::testing::box(-5, -5, -5, -4, -4, -4));
  Collector collector;
  broadphase_->aabbTest(btVector3(0, 0, 0), btVector3(1, 1, 1), collector);
  EXPECT_EQ(collector.ids, (std::set<int>{touching}));
  broadphase_->getBroadphaseAabb(lo, hi);
  EXPECT_EQ(lo, btVector3(-5, -5, -5));
  EXPECT_EQ(hi, btVector3(2, 2, 2));
}

TEST_P(PairFinderBroadphaseTest, ResetPoolNumbersFromZeroAgain) {
  const ObjectBounds unit = finders::testing::box(0, 0, 0, 1, 1, 1);
  std::vector<btBroadphaseProxy*> proxies = {create(unit), create(unit), create(unit)};
  for (btBroadphaseProxy* proxy : proxies) broadphase_->destroyProxy(proxy, &dispatcher_);
  broadphase_->calculateOverlappingPairs(&dispatcher_);
  broadphase_->resetPool(&dispatcher_);
  EXPECT_EQ(create(unit)->m_uniqueId, 0);
  EXPECT_EQ(create(unit)->m_uniqueId, 1);
}

TEST_P(PairFinderBroadphaseTest, RejectsMisuse) {
  btBroadphaseProxy* proxy = create(finders::testing::box(0, 0, 0, 1, 1, 1));
  broadphase_->destroyProxy(proxy, &dispatcher_);
  EXPECT_THROW(broadphase_->destroyProxy(proxy, &dispatcher_), std::runtime_error);
}

// A finder that keeps what launchWithChanges() was told and finds nothing.
class ChangeRecorder final : public finders::PairFinder {
 public:
  explicit ChangeRecorder(std::vector<std::vector<std::uint32_t>>* heard) : heard_(heard) {}
  std::string_view name() const override { return "recorder"; }

 private:
  void startSearch(std::span<const ObjectBounds> /*objects*/,
                   const std::span<const std::uint32_t>* changed) override {
    if (changed == nullptr) {
      heard_->push_back({999});
      return;
    }
    heard_->emplace_back(changed->begin(), changed->end());
    std::sort(heard_->back().begin(), heard_->back().end());
  }
  finders::PairDelta finishSearch() override { return {}; }
  finders::SearchStats searchStats() const override { return {}; }

 private:
  std::vector<std::vector<std::uint32_t>>* heard_;
};

TEST(PairFinderBroadphaseChangesTest, TheFinderHearsOnlyTheSlotsWhoseEntryChanged) {
  std::vector<std::vector<std::uint32_t>> heard;
  PairFinderBroadphase broadphase(std::make_unique<ChangeRecorder>(&heard));
  btDefaultCollisionConfiguration configuration;
  btCollisionDispatcher dispatcher(&configuration);
  const auto create = [&](float x) {
    return broadphase.createProxy(btVector3(x, 0, 0), btVector3(x + 1, 1, 1), BOX_SHAPE_PROXYTYPE,
                                  nullptr, kDefault, kAll, &dispatcher);
  };
  std::vector<btBroadphaseProxy*> proxies = {create(0), create(2), create(4), create(6)};
  broadphase.calculateOverlappingPairs(&dispatcher);
  // Slot 0 written with its own box, slot 1 moved twice, slot 2 made
  // unusable, slot 3 destroyed: 1, 2 and 3 changed, each named once.
  broadphase.setAabb(proxies[0], btVector3(0, 0, 0), btVector3(1, 1, 1), &dispatcher);
  broadphase.setAabb(proxies[1], btVector3(3, 0, 0), btVector3(4, 1, 1), &dispatcher);
  broadphase.setAabb(proxies[1], btVector3(5, 0, 0), btVector3(6, 1, 1), &dispatcher);
  broadphase.setAabb(proxies[2], btVector3(NAN, 0, 0), btVector3(5, 1, 1), &dispatcher);
  broadphase.destroyProxy(proxies[3], &dispatcher);
  broadphase.calculateOverlappingPairs(&dispatcher);
  // Nothing written: nothing changed.
  broadphase.calculateOverlappingPairs(&dispatcher);
  ASSERT_EQ(heard.size(), 3u);
  EXPECT_EQ(heard[0], (std::vector<std::uint32_t>{0, 1, 2, 3}));
  EXPECT_EQ(heard[1], (std::vector<std::uint32_t>{1, 2, 3}));
  EXPECT_TRUE(heard[2].empty());
}

TEST_P(PairFinderBroadphaseTest, FillsTheFindersStagingSoItCopiesNoBoxes) {
  std::vector<btBroadphaseProxy*> live;
  for (const ObjectBounds& b :
       finders::testing::makeBoxes(finders::testing::BoxSet::kRandom, 300, 0)) {
    live.push_back(create(b, b.group, b.mask));
  }
  for (int frame = 1; frame < 5; ++frame) {
    const auto moved = finders::testing::makeBoxes(finders::testing::BoxSet::kRandom,
                                                   static_cast<std::uint32_t>(live.size()), frame);
    for (std::size_t i = 0; i < live.size(); ++i) {
      broadphase_->setAabb(live[i], minOf(moved[i]), maxOf(moved[i]), &dispatcher_);
    }
    if (frame == 3) live.push_back(create(moved[0]));  // a new slot
    broadphase_->calculateOverlappingPairs(&dispatcher_);
    EXPECT_TRUE(finders::testing::samePairs(cachedPairs(), expectedPairs(live)))
        << "frame " << frame;
    // gpubf has a staging, filled by the broadphase; the others copy as before.
    if (GetParam() == "gpubf") {
      EXPECT_EQ(broadphase_->lastSearchStats().device.host_bytes_copied, 0u) << "frame " << frame;
    }
  }
}

// A finder with a staging area that checks, at each launch, that it was
// handed the staging; the staging drops its contents whenever it grows.
class StagingChecker final : public finders::PairFinder {
 public:
  explicit StagingChecker(std::vector<std::vector<ObjectBounds>>* seen) : seen_(seen) {}
  std::string_view name() const override { return "staging checker"; }

 private:
  std::span<ObjectBounds> staging(std::size_t count) override {
    if (count > staging_.size()) {
      staging_ = std::vector<ObjectBounds>(2 * count);
      std::memset(staging_.data(), 0xA5, staging_.size() * sizeof(ObjectBounds));
    }
    return {staging_.data(), count};
  }
  void startSearch(std::span<const ObjectBounds> objects,
                   const std::span<const std::uint32_t>* /*changed*/) override {
    EXPECT_EQ(objects.data(), staging_.data()) << "launched without the staging";
    seen_->emplace_back(objects.begin(), objects.end());
  }
  finders::PairDelta finishSearch() override { return {}; }
  finders::SearchStats searchStats() const override { return {}; }

  std::vector<ObjectBounds> staging_;
  std::vector<std::vector<ObjectBounds>>* seen_;
};

TEST(PairFinderBroadphaseStagingTest, TheStagingHoldsEveryEntryAtEachLaunch) {
  std::vector<std::vector<ObjectBounds>> seen;
  PairFinderBroadphase broadphase(std::make_unique<StagingChecker>(&seen));
  btDefaultCollisionConfiguration configuration;
  btCollisionDispatcher dispatcher(&configuration);
  std::vector<float> x;  // each slot's box is [x, x + 1] x [0, 1]^2
  std::vector<btBroadphaseProxy*> proxies;
  const auto create = [&](float at) {
    x.push_back(at);
    proxies.push_back(broadphase.createProxy(btVector3(at, 0, 0), btVector3(at + 1, 1, 1),
                                             BOX_SHAPE_PROXYTYPE, nullptr, kDefault, kAll,
                                             &dispatcher));
  };
  const auto move = [&](std::size_t slot, float at) {
    x[slot] = at;
    broadphase.setAabb(proxies[slot], btVector3(at, 0, 0), btVector3(at + 1, 1, 1), &dispatcher);
  };
  const auto expectSeenMatches = [&](const char* when) {
    ASSERT_FALSE(seen.empty()) << when;
    ASSERT_EQ(seen.back().size(), x.size()) << when;
    for (std::size_t slot = 0; slot < x.size(); ++slot) {
      EXPECT_EQ(seen.back()[slot].min[0], x[slot]) << when << ", slot " << slot;
      EXPECT_EQ(seen.back()[slot].max[0], x[slot] + 1) << when << ", slot " << slot;
    }
  };
  for (int i = 0; i < 3; ++i) create(3.0f * static_cast<float>(i));
  broadphase.calculateOverlappingPairs(&dispatcher);
  expectSeenMatches("first launch");
  move(1, 20);  // written straight into the staging
  broadphase.calculateOverlappingPairs(&dispatcher);
  expectSeenMatches("after a move");
  for (int i = 0; i < 5; ++i) create(40.0f + static_cast<float>(i));  // the staging grows
  move(0, 7);
  broadphase.calculateOverlappingPairs(&dispatcher);
  expectSeenMatches("after new slots");
  move(2, 30);
  move(2, 31);  // twice between searches: the staging holds the last
  broadphase.calculateOverlappingPairs(&dispatcher);
  expectSeenMatches("after two moves of one box");
}

INSTANTIATE_TEST_SUITE_P(AllFinders, PairFinderBroadphaseTest,
                         ::testing::ValuesIn(finders::testing::finderNames()),
                         finders::testing::finderTestName);
}  // namespace
}  // namespace overlap::physics
