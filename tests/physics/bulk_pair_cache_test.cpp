// BulkPairCache against Bullet's btHashedOverlappingPairCache: given a
// finder's changes in bulk it must hold the same pairs in the same order,
// and tell the ghost callback the same adds and removals in the same order,
// as Bullet's cache given the same changes one call at a time (the path the
// adapter took before).  Every finder's changes are replayed (GPU ones skip
// without a device), with boxes moving, proxies leaving and coming back, and
// proxy filters that refuse some of the finder's pairs.  The rest of the
// btOverlappingPairCache interface is checked against Bullet's cache too.
#include "physics/broadphase/bulk_pair_cache.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "tests/gpu/pair_test_support.h"
#include "tests/needs_device.h"

namespace overlap::physics {
namespace {

using finders::IndexPair;
using finders::ObjectBounds;

// Every add and removal the ghost callback hears, in order, as (id0, id1).
class CallLog : public btOverlappingPairCallback {
 public:
  btBroadphasePair* addOverlappingPair(btBroadphaseProxy* p0, btBroadphaseProxy* p1) override {
    calls.push_back({+1, p0->m_uniqueId, p1->m_uniqueId});
    return nullptr;
  }
  void* removeOverlappingPair(btBroadphaseProxy* p0, btBroadphaseProxy* p1,
                              btDispatcher* /*dispatcher*/) override {
    calls.push_back({-1, p0->m_uniqueId, p1->m_uniqueId});
    return nullptr;
  }
  void removeOverlappingPairsContainingProxy(btBroadphaseProxy* /*proxy*/,
                                             btDispatcher* /*dispatcher*/) override {}
  std::vector<std::array<int, 3>> calls;
};

// The same calls reach both caches; `expectSame` compares them.
struct TwoCaches {
  TwoCaches() {
    // Through the interface: btHashedOverlappingPairCache makes some of its
    // overrides private.
    static_cast<btOverlappingPairCache&>(bullet).setInternalGhostPairCallback(&bullet_log);
    bulk.setInternalGhostPairCallback(&bulk_log);
  }
  btHashedOverlappingPairCache bullet;
  BulkPairCache bulk;
  CallLog bullet_log, bulk_log;
};

::testing::AssertionResult sameArrays(btOverlappingPairCache& expected,
                                      btOverlappingPairCache& actual) {
  const btBroadphasePairArray& x = expected.getOverlappingPairArray();
  const btBroadphasePairArray& y = actual.getOverlappingPairArray();
  if (x.size() != y.size()) {
    return ::testing::AssertionFailure() << x.size() << " pairs expected, " << y.size() << " held";
  }
  for (int i = 0; i < x.size(); ++i) {
    if (x[i].m_pProxy0 != y[i].m_pProxy0 || x[i].m_pProxy1 != y[i].m_pProxy1) {
      return ::testing::AssertionFailure()
             << "pair " << i << ": expected (" << x[i].m_pProxy0->m_uniqueId << ", "
             << x[i].m_pProxy1->m_uniqueId << "), held (" << y[i].m_pProxy0->m_uniqueId << ", "
             << y[i].m_pProxy1->m_uniqueId << ")";
    }
  }
  return ::testing::AssertionSuccess();
}

void expectSame(TwoCaches& caches) {
  EXPECT_TRUE(sameArrays(caches.bullet, caches.bulk));
  EXPECT_EQ(caches.bulk_log.calls, caches.bullet_log.calls);
  // Every held pair is found where it is.
  btBroadphasePairArray& pairs = caches.bulk.getOverlappingPairArray();
  for (int i = 0; i < pairs.size(); ++i) {
    ASSERT_EQ(caches.bulk.findPair(pairs[i].m_pProxy1, pairs[i].m_pProxy0), &pairs[i]);
  }
}

// A pile of boxes that jitter, so that pairs start and stop every frame.
class Scene {
 public:
  explicit Scene(std::size_t count) : boxes_(count), proxies_(count) {
    for (std::size_t i = 0; i < count; ++i) {
      centres_.push_back({place_(random_), place_(random_), place_(random_)});
      proxies_[i].m_uniqueId = static_cast<int>(i);
      proxies_[i].m_collisionFilterGroup = btBroadphaseProxy::DefaultFilter;
      proxies_[i].m_collisionFilterMask = btBroadphaseProxy::AllFilter;
      // Some proxies refuse each other where the finder sees no filter: the
      // cache's own filter decides, and removals of pairs it never held are
      // no-ops in both caches.
      if (i % 7 == 3) proxies_[i].m_collisionFilterMask = ~btBroadphaseProxy::StaticFilter;
      if (i % 11 == 5) proxies_[i].m_collisionFilterGroup = btBroadphaseProxy::StaticFilter;
      live_.push_back(&proxies_[i]);
    }
  }

  std::span<const ObjectBounds> nextFrame() {
    for (std::size_t i = 0; i < boxes_.size(); ++i) {
      for (int axis = 0; axis < 3; ++axis) {
        centres_[i][axis] += step_(random_);
        boxes_[i].min[axis] = centres_[i][axis] - 0.5f;
        boxes_[i].max[axis] = centres_[i][axis] + 0.5f;
      }
      const bool live = live_[i] != nullptr;
      boxes_[i].group = live ? 1 : 0;
      boxes_[i].mask = live ? -1 : 0;
    }
    return boxes_;
  }

  // Takes a few proxies out (both caches drop their pairs, as destroyProxy
  // does) and brings back the ones taken out before.
  void churn(TwoCaches& caches, btDispatcher* dispatcher) {
    for (std::size_t i = 0; i < boxes_.size(); ++i) {
      if (live_[i] == nullptr) {
        if (pick_(random_) < 0.5) live_[i] = &proxies_[i];
      } else if (pick_(random_) < 0.02) {
        caches.bullet.removeOverlappingPairsContainingProxy(live_[i], dispatcher);
        caches.bulk.removeOverlappingPairsContainingProxy(live_[i], dispatcher);
        live_[i] = nullptr;
      }
    }
  }

  std::span<btBroadphaseProxy* const> live() const { return live_; }

 private:
  std::mt19937 random_{20261127};
  std::uniform_real_distribution<float> place_{0.0f, 9.0f};
  std::normal_distribution<float> step_{0.0f, 0.15f};
  std::uniform_real_distribution<double> pick_{0.0, 1.0};
  std::vector<std::array<float, 3>> centres_;
  std::vector<ObjectBounds> boxes_;
  std::vector<btBroadphaseProxy> proxies_;
  std::vector<btBroadphaseProxy*> live_;  // null: out, as a destroyed proxy
};

// What the adapter did before the bulk cache: each change, one call at a time.
void applyOneByOne(btOverlappingPairCache& cache, const finders::PairDelta& delta,
                   std::span<btBroadphaseProxy* const> live, btDispatcher* dispatcher) {
  for (const IndexPair& pair : delta.removed) {
    if (live[pair.a] != nullptr && live[pair.b] != nullptr) {
      cache.removeOverlappingPair(live[pair.a], live[pair.b], dispatcher);
    }
  }
  for (const IndexPair& pair : delta.added) {
    if (live[pair.a] != nullptr && live[pair.b] != nullptr) {
      cache.addOverlappingPair(live[pair.a], live[pair.b]);
    }
  }
}

class BulkPairCacheFinders : public ::testing::TestWithParam<std::string_view> {};

TEST_P(BulkPairCacheFinders, HoldsTheSamePairsInTheSameOrderAsBulletsCacheCallByCall) {
  OVERLAP_NEEDS_DEVICE_FOR(GetParam());
  const std::unique_ptr<finders::PairFinder> finder = finders::makePairFinder(GetParam());
  TwoCaches caches;
  Scene scene(600);
  std::size_t changes = 0, most_pairs = 0;
  for (int frame = 0; frame < 40; ++frame) {
    finder->launch(scene.nextFrame());
    const finders::PairDelta delta = finder->finish();
    changes += delta.added.size() + delta.removed.size();
    applyOneByOne(caches.bullet, delta, scene.live(), nullptr);
    caches.bulk.applyChanges(delta.removed, delta.added, scene.live(), nullptr);
    expectSame(caches);
    if (HasFatalFailure()) return;
    most_pairs =
        std::max(most_pairs, static_cast<std::size_t>(caches.bulk.getNumOverlappingPairs()));
    scene.churn(caches, nullptr);
    expectSame(caches);
  }
  EXPECT_GT(most_pairs, 500u) << "the pile should be in contact";
  EXPECT_GT(changes, 2000u) << "pairs should start and stop";
}

INSTANTIATE_TEST_SUITE_P(AllFinders, BulkPairCacheFinders,
                         ::testing::ValuesIn(finders::testing::finderNames()),
                         finders::testing::finderTestName);

// Records the visits; where `remove`, removes every pair whose ids sum to a
// multiple of 3.  (Bullet's deterministic visit cannot remove: after a
// removal it visits the same place again, and where that was the last pair
// it finds the stale copy and loops for ever.  The dispatcher never removes.)
struct RecordVisits : btOverlapCallback {
  explicit RecordVisits(bool remove_some) : remove(remove_some) {}
  bool processOverlap(btBroadphasePair& pair) override {
    const int sum = pair.m_pProxy0->m_uniqueId + pair.m_pProxy1->m_uniqueId;
    visits.push_back(sum * 100000 + pair.m_pProxy0->m_uniqueId);
    return remove && sum % 3 == 0;
  }
  bool remove;
  std::vector<int> visits;
};

// Fills both caches through the one-call interface, in a scattered order.
void fillScattered(TwoCaches& caches, std::vector<btBroadphaseProxy>& proxies) {
  for (std::size_t i = 0; i < proxies.size(); ++i) {
    proxies[i].m_uniqueId = static_cast<int>(i);
    proxies[i].m_collisionFilterGroup = btBroadphaseProxy::DefaultFilter;
    proxies[i].m_collisionFilterMask = btBroadphaseProxy::AllFilter;
  }
  std::mt19937 random(7);
  std::uniform_int_distribution<std::size_t> pick(0, proxies.size() - 1);
  for (int n = 0; n < 3000; ++n) {
    btBroadphaseProxy* x = &proxies[pick(random)];
    btBroadphaseProxy* y = &proxies[pick(random)];
    if (x == y) continue;
    if (n % 5 == 4) {
      EXPECT_EQ(caches.bulk.removeOverlappingPair(x, y, nullptr) == nullptr,
                caches.bullet.removeOverlappingPair(x, y, nullptr) == nullptr);
    } else {
      EXPECT_EQ(caches.bulk.addOverlappingPair(x, y) == nullptr,
                caches.bullet.addOverlappingPair(x, y) == nullptr);
    }
  }
  expectSame(caches);
}

// Both caches filled by fillScattered, and a dispatch info asking for
// Bullet's deterministic visit or not.
struct Scattered {
  explicit Scattered(bool deterministic) {
    fillScattered(caches, proxies);
    info.m_deterministicOverlappingPairs = deterministic;
  }
  TwoCaches caches;
  std::vector<btBroadphaseProxy> proxies = std::vector<btBroadphaseProxy>(200);
  btDispatcherInfo info;
};

TEST(BulkPairCache, VisitsRemovesAndSortsAsBulletsCacheDoes) {
  for (const bool deterministic : {false, true}) {
    Scattered scattered(deterministic);
    TwoCaches& caches = scattered.caches;
    const btDispatcherInfo& info = scattered.info;
    RecordVisits bullet_visits(!deterministic), bulk_visits(!deterministic);
    caches.bullet.processAllOverlappingPairs(&bullet_visits, nullptr, info);
    caches.bulk.processAllOverlappingPairs(&bulk_visits, nullptr, info);
    EXPECT_EQ(bulk_visits.visits, bullet_visits.visits) << "deterministic " << deterministic;
    EXPECT_GT(bullet_visits.visits.size(), 100u);
    expectSame(caches);
    caches.bullet.removeOverlappingPairsContainingProxy(&scattered.proxies[17], nullptr);
    caches.bulk.removeOverlappingPairsContainingProxy(&scattered.proxies[17], nullptr);
    expectSame(caches);
    static_cast<btOverlappingPairCache&>(caches.bullet).sortOverlappingPairs(nullptr);
    caches.bulk.sortOverlappingPairs(nullptr);
    expectSame(caches);
  }
}

// A subset's visit keeps the full visit's order (the dispatcher's serial
// pass sorts only the pairs that have serial work), and refuses removal.
TEST(BulkPairCache, VisitsASubsetOfPairsInTheOrderOfTheFullVisit) {
  for (const bool deterministic : {false, true}) {
    Scattered scattered(deterministic);
    TwoCaches& caches = scattered.caches;
    const btDispatcherInfo& info = scattered.info;
    RecordVisits all(false);
    caches.bulk.processAllOverlappingPairs(&all, nullptr, info);
    // Every third pair, and the first and the last, given in array order.
    std::vector<int> subset;
    const int count = caches.bulk.getNumOverlappingPairs();
    for (int i = 0; i < count; ++i) {
      if (i % 3 == 0 || i == count - 1) subset.push_back(i);
    }
    std::vector<int> expected;
    btBroadphasePairArray& pairs = caches.bulk.getOverlappingPairArray();
    for (const int visit : all.visits) {
      for (const int i : subset) {
        const btBroadphasePair& pair = pairs[i];
        const int sum = pair.m_pProxy0->m_uniqueId + pair.m_pProxy1->m_uniqueId;
        if (sum * 100000 + pair.m_pProxy0->m_uniqueId == visit) expected.push_back(visit);
      }
    }
    ASSERT_EQ(expected.size(), subset.size());
    RecordVisits some(false);
    caches.bulk.processPairsInVisitOrder(subset, &some, info);
    EXPECT_EQ(some.visits, expected) << "deterministic " << deterministic;
    RecordVisits removing(true);
    EXPECT_THROW(caches.bulk.processPairsInVisitOrder(subset, &removing, info), std::logic_error);
    expectSame(caches);
  }
}

TEST(BulkPairCache, AnOverlapFilterDecidesWhatIsAdded) {
  struct EvenOnly : btOverlapFilterCallback {
    bool needBroadphaseCollision(btBroadphaseProxy* p0, btBroadphaseProxy* p1) const override {
      return (p0->m_uniqueId + p1->m_uniqueId) % 2 == 0;
    }
  } even_only;
  BulkPairCache cache;
  cache.setOverlapFilterCallback(&even_only);
  EXPECT_EQ(cache.getOverlapFilterCallback(), &even_only);
  std::vector<btBroadphaseProxy> proxies(3);
  for (int i = 0; i < 3; ++i) proxies[static_cast<std::size_t>(i)].m_uniqueId = i;
  EXPECT_EQ(cache.addOverlappingPair(&proxies[0], &proxies[1]), nullptr);
  btBroadphasePair* pair = cache.addOverlappingPair(&proxies[2], &proxies[0]);
  ASSERT_NE(pair, nullptr);
  EXPECT_EQ(pair->m_pProxy0, &proxies[0]);
  EXPECT_EQ(cache.addOverlappingPair(&proxies[0], &proxies[2]), pair) << "added twice";
  EXPECT_EQ(cache.getNumOverlappingPairs(), 1);
  EXPECT_EQ(cache.findPair(&proxies[0], &proxies[1]), nullptr);
}

TEST(BulkPairCache, RefusesToGrowPastItsMemoryLimitAndKeepsThePairsItHeld) {
  constexpr std::uint64_t kLimit = 64 * 1024;
  BulkPairCache cache;
  cache.setMemoryLimit(kLimit);
  std::vector<std::pair<btBroadphaseProxy*, btBroadphaseProxy*>> held;
  std::vector<btBroadphaseProxy> proxies(100);
  for (std::size_t i = 0; i < proxies.size(); ++i) {
    proxies[i].m_uniqueId = static_cast<int>(i);
    proxies[i].m_collisionFilterGroup = btBroadphaseProxy::DefaultFilter;
    proxies[i].m_collisionFilterMask = btBroadphaseProxy::AllFilter;
  }
  bool refused = false;
  for (btBroadphaseProxy& a : proxies) {
    for (btBroadphaseProxy& b : proxies) {
      if (a.m_uniqueId >= b.m_uniqueId || refused) continue;
      if (cache.addOverlappingPair(&a, &b) == nullptr) {
        refused = true;
        continue;
      }
      held.emplace_back(&a, &b);
    }
  }
  ASSERT_TRUE(refused) << "4950 pairs fit in " << kLimit << " bytes";
  // Once refused it adds nothing more, and says why when asked.
  EXPECT_EQ(cache.addOverlappingPair(&proxies[98], &proxies[99]), nullptr);
  try {
    cache.throwIfRefused();
    FAIL() << "the refusal was not kept";
  } catch (const PairMemoryError& error) {
    // Handed over one by one, the pairs are more than those held.
    EXPECT_EQ(error.pairs, held.size());
    EXPECT_TRUE(error.more_than);
    EXPECT_GT(error.bytes, kLimit);
    EXPECT_EQ(error.limit, kLimit);
    EXPECT_NE(std::string(error.what())
                  .find("more than " + std::to_string(held.size()) + " pairs need more than"),
              std::string::npos)
        << error.what();
  }
  EXPECT_GT(held.size(), 500u);
  EXPECT_LE(cache.bytesHeld(), kLimit);
  ASSERT_EQ(cache.getNumOverlappingPairs(), static_cast<int>(held.size()));
  for (const auto& [a, b] : held) {
    const btBroadphasePair* pair = cache.findPair(b, a);
    ASSERT_NE(pair, nullptr);
    EXPECT_EQ(pair->m_pProxy0, a);
  }
}

}  // namespace
}  // namespace overlap::physics
