// The narrowphase on the task system (physics/parallel_dispatcher.h) gives
// the contacts of Bullet's serial dispatch bit for bit, in the same order,
// with our finders' search beside it or not, for every broadphase: checked
// after every frame of a scene-4 pile, with CCD on every box and with the
// default, on systems of 2 and 4 threads (plain threads: all of them run).
#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "gpu/base/checksum.h"
#include "physics/broadphase/broadphase_factory.h"
#include "physics/parallel_dispatcher.h"
#include "tests/physics/narrowphase_support.h"

namespace overlap::physics {
namespace {

using testing::firstDifferentFrame;
using testing::runContacts;

class Narrowphase : public ::testing::TestWithParam<std::string_view> {};

TEST_P(Narrowphase, ParallelAndBesideTheSearchGiveTheSerialContactsEveryFrame) {
  const std::string algorithm(GetParam());
  const auto one = makeTaskSystem(1);
  for (const CcdMode ccd : {CcdMode::kAuto, CcdMode::kAll}) {
    const testing::ContactRun serial =
        runContacts(algorithm, NarrowphaseMode::kBullet, *one, 4, 500, 25, ccd);
    for (const int threads : {2, 4}) {
      const auto tasks = makeTaskSystem(threads, TaskBackEnd::kPlainThreads);
      for (const NarrowphaseMode mode :
           {NarrowphaseMode::kParallel, NarrowphaseMode::kBesideSearch}) {
        const testing::ContactRun run = runContacts(algorithm, mode, *tasks, 4, 500, 25, ccd);
        EXPECT_EQ(firstDifferentFrame(serial, run), -1)
            << serial.algorithm << ", " << narrowphaseModeName(mode) << ", " << threads
            << " threads, CCD " << ccdModeName(ccd);
        EXPECT_EQ(run.state, serial.state);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(EveryBroadphase, Narrowphase, ::testing::ValuesIn(broadphaseNames()),
                         [](const ::testing::TestParamInfo<std::string_view>& info) {
                           std::string name(info.param);
                           for (char& c : name) {
                             if (c == '-') c = '_';
                           }
                           return name;
                         });

// A plain Bullet world of falling boxes on a floor, stepped by Bullet's own
// loop: only the dispatcher differs between two of them.
class BoxWorld {
 public:
  explicit BoxWorld(TaskSystem* tasks) {
    dispatcher_ = tasks != nullptr ? std::make_unique<ParallelDispatcher>(&config_, *tasks)
                                   : std::make_unique<btCollisionDispatcher>(&config_);
    world_ = std::make_unique<btDiscreteDynamicsWorld>(dispatcher_.get(), &broadphase_, &solver_,
                                                       &config_);
    world_->getDispatchInfo().m_deterministicOverlappingPairs = true;
    addBody(btVector3(50, 1, 50), btVector3(0, -1, 0), 0);
    for (int i = 0; i < 60; ++i) {
      addBody(btVector3(0.5f, 0.5f, 0.5f),
              btVector3(static_cast<float>(i % 4) * 0.9f, 0.6f + static_cast<float>(i / 4) * 1.05f,
                        static_cast<float>(i % 3) * 0.7f),
              1);
    }
  }
  ~BoxWorld() {
    for (auto& body : bodies_) world_->removeRigidBody(body.get());
  }

  void step() { world_->stepSimulation(1.0f / 60, 0); }
  std::uint64_t contacts() const {
    std::uint64_t hash = kFnv1aOffsetBasis;
    for (int m = 0; m < dispatcher_->getNumManifolds(); ++m) {
      const btPersistentManifold& manifold = *dispatcher_->getManifoldByIndexInternal(m);
      const int head[] = {manifold.getBody0()->getUserIndex(), manifold.getBody1()->getUserIndex(),
                          manifold.getNumContacts()};
      hash = fnv1a(std::span<const int>(head), hash);
      for (int p = 0; p < manifold.getNumContacts(); ++p) {
        const btManifoldPoint& point = manifold.getContactPoint(p);
        hash = fnv1a(std::span<const btScalar>(point.m_positionWorldOnB.m_floats, 3), hash);
        hash = fnv1a(std::span<const btScalar>(point.m_normalWorldOnB.m_floats, 3), hash);
        hash = fnv1a(std::span<const btScalar>(&point.m_distance1, 1), hash);
      }
    }
    return hash;
  }
  btCollisionDispatcher& dispatcher() { return *dispatcher_; }

 private:
  void addBody(const btVector3& half, const btVector3& at, btScalar mass) {
    shapes_.push_back(std::make_unique<btBoxShape>(half));
    btVector3 inertia(0, 0, 0);
    if (mass > 0) shapes_.back()->calculateLocalInertia(mass, inertia);
    btRigidBody::btRigidBodyConstructionInfo info(mass, nullptr, shapes_.back().get(), inertia);
    info.m_startWorldTransform.setOrigin(at);
    bodies_.push_back(std::make_unique<btRigidBody>(info));
    bodies_.back()->setUserIndex(static_cast<int>(bodies_.size()) - 1);
    world_->addRigidBody(bodies_.back().get());
  }

  btDefaultCollisionConfiguration config_;
  std::unique_ptr<btCollisionDispatcher> dispatcher_;
  btDbvtBroadphase broadphase_;
  btSequentialImpulseConstraintSolver solver_;
  std::unique_ptr<btDiscreteDynamicsWorld> world_;
  std::vector<std::unique_ptr<btBoxShape>> shapes_;
  std::vector<std::unique_ptr<btRigidBody>> bodies_;
};

TEST(ParallelDispatcher, RunsTheBoxPairsOnTheTaskSystemWithBulletsContacts) {
  const auto tasks = makeTaskSystem(4, TaskBackEnd::kPlainThreads);
  BoxWorld bullet(nullptr), parallel(tasks.get());
  int most_parallel = 0;
  for (int step = 0; step < 120; ++step) {
    bullet.step();
    parallel.step();
    ASSERT_EQ(parallel.contacts(), bullet.contacts()) << "step " << step;
    most_parallel = std::max(
        most_parallel, static_cast<ParallelDispatcher&>(parallel.dispatcher()).lastParallelPairs());
  }
  EXPECT_GT(most_parallel, 50) << "the box pairs did not run in parallel";
}

TEST(ParallelDispatcher, RunsSeriallyWithAGlobalContactCallback) {
  const auto tasks = makeTaskSystem(4, TaskBackEnd::kPlainThreads);
  BoxWorld parallel(tasks.get());
  gContactStartedCallback = [](btPersistentManifold* const&) {};
  for (int step = 0; step < 30; ++step) parallel.step();
  gContactStartedCallback = nullptr;
  EXPECT_EQ(static_cast<ParallelDispatcher&>(parallel.dispatcher()).lastParallelPairs(), 0);
}

TEST(NarrowphaseModes, NamesRoundTripAndRefuseOthers) {
  for (const NarrowphaseMode mode :
       {NarrowphaseMode::kBullet, NarrowphaseMode::kParallel, NarrowphaseMode::kBesideSearch}) {
    EXPECT_EQ(parseNarrowphaseMode(narrowphaseModeName(mode)), mode);
  }
  EXPECT_THROW(parseNarrowphaseMode("fast"), std::invalid_argument);
}

}  // namespace
}  // namespace overlap::physics
