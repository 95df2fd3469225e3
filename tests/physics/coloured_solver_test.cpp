// The coloured contact solver (physics/coloured_solver.h): its batches keep
// the moving bodies apart and never write the shared fixed body, the world
// uses it by default, and its state is the same for every thread count.
#include "physics/coloured_solver.h"

#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>

#include "physics/world.h"
#include "tests/physics/thread_count_states.h"

namespace overlap::physics {
namespace {

SceneConfig smallScene(int scene, int objects) {
  SceneConfig config = SceneConfig::forScene(scene);
  config.objects = objects;
  config.seed = 42;
  return config;
}

const ColouredConstraintSolver* colouredSolverOf(PhysicsWorld& world) {
  return dynamic_cast<const ColouredConstraintSolver*>(world.bulletWorld().getConstraintSolver());
}

// Every frame's last batches, in every scene: no two pieces of a batch hold
// one moving body, no row names the shared fixed body, and each fixed-body
// copy is written from one piece of a batch.
TEST(ColouredSolver, NoBatchSharesAMovingBodyOrWritesTheFixedBodyFromTwoPieces) {
  for (int scene = 1; scene <= 4; ++scene) {
    WorldOptions options{"cpusap"};
    options.solver_order = SolverOrder::kColoured;
    PhysicsWorld world(smallScene(scene, 400), options);
    const ColouredConstraintSolver* solver = colouredSolverOf(world);
    ASSERT_NE(solver, nullptr);
    int wall_rows = 0;
    int shared_pieces = 0;  // batches of more than one piece: the check has pieces to tell apart
    for (int frame = 0; frame < 40; ++frame) {
      world.stepFrame();
      const ContactBatches& batches = solver->lastBatches();
      ASSERT_EQ(batchProblem(batches), "") << "scene " << scene << ", frame " << frame;
      for (const ContactBatches::Manifold& manifold : batches.manifolds) {
        wall_rows += manifold.body_a >= batches.first_copy || manifold.body_b >= batches.first_copy;
      }
      for (int batch = 0; batch < batches.batches(); ++batch) {
        int filled = 0;  // the batch's pieces that hold a manifold
        for (int piece = batches.batch_piece[static_cast<std::size_t>(batch)];
             piece < batches.batch_piece[static_cast<std::size_t>(batch) + 1]; ++piece) {
          filled += batches.piece_begin[static_cast<std::size_t>(piece) + 1] >
                    batches.piece_begin[static_cast<std::size_t>(piece)];
        }
        shared_pieces += filled > 1;
      }
    }
    EXPECT_GT(wall_rows, 0) << "scene " << scene << ": no box met a wall";
    EXPECT_GT(shared_pieces, 0) << "scene " << scene << ": no batch had two pieces";
  }
}

// The check itself finds each breach.
TEST(ColouredSolver, BatchCheckFindsEachBreach) {
  ContactBatches batches;
  batches.moving_bodies = 10;
  batches.fixed_body = 10;
  batches.first_kinematic = 11;
  batches.first_copy = 11;
  batches.copies = 2;
  // Batch 0: pieces {0, 1} and {2}; batch 1: {3}.  A piece is serial: its
  // manifolds may share a body.
  batches.manifolds = {{0, 1}, {1, 11}, {3, 12}, {4, 5}};
  batches.piece_begin = {0, 2, 3, 4};
  batches.batch_piece = {0, 2, 3};
  ASSERT_EQ(batchProblem(batches), "");

  ContactBatches shared_body = batches;
  shared_body.manifolds[2] = {1, 12};
  EXPECT_NE(batchProblem(shared_body).find("both hold moving body 1"), std::string::npos);

  ContactBatches fixed_body = batches;
  fixed_body.manifolds[3] = {4, 10};
  EXPECT_NE(batchProblem(fixed_body).find("shared fixed body"), std::string::npos);

  ContactBatches copy_of_another_piece = batches;
  copy_of_another_piece.manifolds[2] = {3, 11};
  EXPECT_NE(batchProblem(copy_of_another_piece).find("another piece's"), std::string::npos);

  ContactBatches copy_of_a_later_piece = batches;
  copy_of_a_later_piece.manifolds[3] = {4, 12};
  EXPECT_NE(batchProblem(copy_of_a_later_piece).find("another piece's"), std::string::npos);

  ContactBatches gap = batches;
  gap.piece_begin = {0, 2, 3, 3};
  EXPECT_NE(batchProblem(gap).find("do not cover"), std::string::npos);
}

// The splits stop while a region keeps kBodiesPerRegion bodies: one region
// for a small pile (Bullet's order), more as the pile grows, and the regions
// are the moving bodies split in equal halves.
TEST(ColouredSolver, RegionsKeepTheFewestBodiesARegion) {
  for (const auto& [objects, regions] : {std::pair{150, 1}, {450, 2}, {850, 4}}) {
    WorldOptions options{"cpusap"};
    PhysicsWorld world(smallScene(4, objects), options);
    const ColouredConstraintSolver* solver = colouredSolverOf(world);
    ASSERT_NE(solver, nullptr);
    world.stepFrame();
    EXPECT_EQ(solver->lastBatches().regions, regions) << objects << " boxes";
    if (regions > 1) {
      EXPECT_GE(solver->lastBatches().moving_bodies,
                regions * ColouredConstraintSolver::kBodiesPerRegion)
          << objects << " boxes";
    }
  }
}

// The world solves with the coloured solver unless told otherwise, and with
// Bullet's serial one when told: the two sweep in different orders, so
// their piles differ, both finite and contained.
TEST(ColouredSolver, IsTheDefaultAndBulletsSerialSolverIsSelectable) {
  const SceneConfig config = smallScene(4, 300);
  const WorldOptions coloured_options{"cpusap"};
  PhysicsWorld coloured(config, coloured_options);
  WorldOptions serial_options{"cpusap"};
  serial_options.solver_order = SolverOrder::kSerial;
  PhysicsWorld serial(config, serial_options);
  ASSERT_NE(colouredSolverOf(coloured), nullptr);
  EXPECT_EQ(colouredSolverOf(serial), nullptr);
  for (int frame = 0; frame < 30; ++frame) {
    for (PhysicsWorld* world : {&coloured, &serial}) {
      const FrameReport report = world->stepFrame();
      ASSERT_TRUE(std::isfinite(report.kinetic_energy)) << "frame " << frame;
      ASSERT_EQ(report.escaped, 0) << "frame " << frame;
    }
  }
  EXPECT_GT(colouredSolverOf(coloured)->batchesMade(), 0);
  EXPECT_NE(coloured.stateHash(), serial.stateHash());
}

// The batches only reorder Bullet's sweep: unsplit (one piece, in manifold
// order) the coloured solver's setup, rows and write-back give Bullet's
// serial solver's state bit for bit.
TEST(ColouredSolver, UnsplitIsBulletsSerialSolverBitForBit) {
  for (const SolverMode mode : {SolverMode::kPile, SolverMode::kBullet}) {
    for (int scene = 1; scene <= 4; ++scene) {
      WorldOptions options{"cpusap"};
      options.solver = mode;
      options.solver_order = SolverOrder::kSerial;
      PhysicsWorld serial(smallScene(scene, 200), options);
      PhysicsWorld uncoloured(smallScene(scene, 200), options);
      ColouredConstraintSolver unsplit(defaultTaskSystem(), ColouredConstraintSolver::Split::kNone);
      uncoloured.bulletWorld().setConstraintSolver(&unsplit);
      for (int frame = 0; frame < 30; ++frame) {
        serial.stepFrame();
        uncoloured.stepFrame();
        ASSERT_EQ(serial.stateHash(), uncoloured.stateHash())
            << "scene " << scene << ", solver " << solverModeName(mode) << ", frame " << frame;
      }
      EXPECT_GT(unsplit.batchesMade(), 0);
      EXPECT_EQ(unsplit.lastBatches().regions, 0);
      EXPECT_LE(unsplit.lastBatches().batches(), 1);
    }
  }
}

// One state for every thread count: the coloured solver (and the rest of the
// step) reach the same state on 1, 2, 3, 8 and 16 threads, with CCD on every
// box and with the default CCD, in scenes 1 and 2 (3 and 4, with more contacts
// through the same code, are coloured_solver_long_test.cpp's).
class SameStateForEveryThreadCount : public ::testing::TestWithParam<int> {};

TEST_P(SameStateForEveryThreadCount, WithCcdOnEveryBoxAndWithTheDefault) {
  EXPECT_EQ(testing::whereThreadCountsDiffer(GetParam(), 250, 60), "") << "scene " << GetParam();
}

INSTANTIATE_TEST_SUITE_P(Scenes, SameStateForEveryThreadCount, ::testing::Values(1, 2));

TEST(ColouredSolver, SolverOrderNamesParseBothWays) {
  for (const SolverOrder order : {SolverOrder::kColoured, SolverOrder::kSerial}) {
    EXPECT_EQ(parseSolverOrder(solverOrderName(order)), order);
  }
  EXPECT_THROW(parseSolverOrder("parallel"), std::invalid_argument);
}

}  // namespace
}  // namespace overlap::physics
