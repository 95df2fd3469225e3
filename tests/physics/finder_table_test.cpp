// A finder is added by one row of the table of finders (gpu/pair_finder.h)
// and its own code.  This test adds one that the product does not have, a
// naive O(n^2) loop defined here, to a copy of the product's table, and asks
// a catalogue built on that copy for it by name: it is listed, made, and run
// by Bullet in a small scene, holding cpubf's pairs after every step.
#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <iterator>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "gpu/pair_finder.h"
#include "physics/aabb.h"
#include "physics/broadphase/broadphase_factory.h"
#include "tests/gpu/pair_test_support.h"

namespace overlap::physics {
namespace {

// Every pair tested, this frame's set compared with last frame's.
class NaiveFinder final : public finders::PairFinder {
 public:
  std::string_view name() const override { return "naive"; }

 private:
  void startSearch(std::span<const finders::ObjectBounds> objects,
                   const std::span<const std::uint32_t>* /*changed*/) override {
    slot_count_ = finders::checkedSlotCount(name(), slot_count_, objects.size());
    std::vector<finders::IndexPair> now = finders::testing::oraclePairs(objects);
    added_.clear();
    removed_.clear();
    std::set_difference(now.begin(), now.end(), last_.begin(), last_.end(),
                        std::back_inserter(added_));
    std::set_difference(last_.begin(), last_.end(), now.begin(), now.end(),
                        std::back_inserter(removed_));
    last_ = std::move(now);
  }
  finders::PairDelta finishSearch() override { return {added_, removed_}; }
  finders::SearchStats searchStats() const override { return {}; }

  std::uint32_t slot_count_ = 0;
  std::vector<finders::IndexPair> last_, added_, removed_;
};

// The product's table and one row more: all it takes to add a finder.
std::vector<finders::PairFinderRow> tableWithNaive() {
  std::vector<finders::PairFinderRow> table(finders::pairFinderTable().begin(),
                                            finders::pairFinderTable().end());
  table.push_back({"naive",
                   false,
                   "every pair tested, one by one",
                   [](TaskSystem&) -> std::unique_ptr<finders::PairFinder> {
                     return std::make_unique<NaiveFinder>();
                   },
                   {.per_pair = 3 * sizeof(finders::IndexPair)}});
  return table;
}

// A 4 x 4 x 3 pile of boxes dropped on a ground under broadphase `name`,
// stepped 90 times: the pair cache after each step, as world indices.
std::vector<PairList> pairsOfAPile(const BroadphaseCatalogue& catalogue, std::string_view name) {
  const BroadphaseChoice choice =
      catalogue.makeWorld(name, btVector3(-20, -5, -20), btVector3(20, 30, 20), 49);
  EXPECT_EQ(choice.name, name);
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btSequentialImpulseConstraintSolver solver;
  btBoxShape ground_shape(btVector3(10, 1, 10));
  btBoxShape box_shape(btVector3(0.5f, 0.5f, 0.5f));
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  bodies.push_back(std::make_unique<btRigidBody>(0, nullptr, &ground_shape));
  bodies.back()->setWorldTransform(btTransform(btQuaternion::getIdentity(), btVector3(0, -1, 0)));
  btVector3 inertia;
  box_shape.calculateLocalInertia(1, inertia);
  for (int i = 0; i < 48; ++i) {
    bodies.push_back(std::make_unique<btRigidBody>(1, nullptr, &box_shape, inertia));
    bodies.back()->setWorldTransform(
        btTransform(btQuaternion(btVector3(0, 1, 0), 0.2f * static_cast<float>(i)),
                    btVector3(1.05f * static_cast<float>(i % 4) - 1.5f,
                              1.0f + 1.1f * static_cast<float>(i / 16),
                              1.05f * static_cast<float>((i / 4) % 4) - 1.5f)));
  }
  btDiscreteDynamicsWorld world(&dispatcher, choice.broadphase.get(), &solver, &config);
  for (const auto& body : bodies) world.addRigidBody(body.get());
  std::vector<PairList> steps;
  for (int step = 0; step < 90; ++step) {
    world.stepSimulation(1.0f / 60.0f, 0);
    const btBroadphasePairArray& array =
        choice.broadphase->getOverlappingPairCache()->getOverlappingPairArray();
    PairList pairs;
    for (int p = 0; p < array.size(); ++p) {
      pairs.push_back(orderedPair(
          static_cast<btCollisionObject*>(array[p].m_pProxy0->m_clientObject)->getWorldArrayIndex(),
          static_cast<btCollisionObject*>(array[p].m_pProxy1->m_clientObject)
              ->getWorldArrayIndex()));
    }
    std::sort(pairs.begin(), pairs.end());
    steps.push_back(std::move(pairs));
  }
  for (const auto& body : bodies) world.removeRigidBody(body.get());
  return steps;
}

TEST(FinderTable, ARowAddedToACopyOfTheTableIsListedAndMadeByName) {
  const std::vector<finders::PairFinderRow> table = tableWithNaive();
  const BroadphaseCatalogue catalogue(table);
  const BroadphaseInfo& naive = catalogue.info("naive");
  EXPECT_TRUE(naive.exact);
  EXPECT_FALSE(naive.needs_device);
  EXPECT_EQ(naive.description, "every pair tested, one by one");
  EXPECT_EQ(catalogue.names().size(), broadphaseNames().size() + 1);
  EXPECT_EQ(catalogue.names().back(), "naive");
  // The product's catalogue is untouched.
  EXPECT_THROW(broadphaseInfo("naive"), std::invalid_argument);
  EXPECT_EQ(finders::makePairFinder("naive", defaultTaskSystem(), table)->name(), "naive");
}

TEST(FinderTable, BulletRunsTheAddedFinderWithCpubfsPairs) {
  const std::vector<finders::PairFinderRow> table = tableWithNaive();
  const BroadphaseCatalogue catalogue(table);
  const std::vector<PairList> naive = pairsOfAPile(catalogue, "naive");
  const std::vector<PairList> cpubf = pairsOfAPile(catalogue, "cpubf");
  ASSERT_EQ(naive.size(), cpubf.size());
  std::size_t pairs = 0;
  for (std::size_t step = 0; step < naive.size(); ++step) {
    ASSERT_EQ(naive[step], cpubf[step]) << "step " << step;
    pairs += naive[step].size();
  }
  EXPECT_GT(pairs, 1000u) << "the pile should be in contact";
}

}  // namespace
}  // namespace overlap::physics
