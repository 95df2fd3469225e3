#include "physics/coloured_solver.h"

#include <BulletCollision/NarrowPhaseCollision/btPersistentManifold.h>
#include <BulletDynamics/ConstraintSolver/btTypedConstraint.h>
#include <BulletDynamics/Dynamics/btRigidBody.h>

#include <algorithm>
#include <bit>
#include <unordered_map>

namespace overlap::physics {
namespace {

constexpr int kUnconverted = -1;  // a body only the serial pass may convert

}  // namespace

std::string colouringProblem(const ContactColouring& colouring) {
  const auto isCopy = [&](int id) {
    return id >= colouring.first_copy && id < colouring.first_copy + colouring.copies;
  };
  for (int batch = 0; batch < colouring.batches(); ++batch) {
    const int begin = colouring.batch_begin[static_cast<std::size_t>(batch)];
    const int end = colouring.batch_begin[static_cast<std::size_t>(batch) + 1];
    const bool overflow = colouring.overflow && batch == colouring.batches() - 1;
    const std::string where = "batch " + std::to_string(batch) + ": ";
    if (overflow) {
      // One piece, in manifold order: it may touch a body more than once.
      if (colouring.copies < 1) return where + "the overflow batch has no fixed-body copy";
      for (int m = begin; m < end; ++m) {
        const auto& manifold = colouring.manifolds[static_cast<std::size_t>(m)];
        for (const int id : {manifold.body_a, manifold.body_b}) {
          if (id == colouring.fixed_body) return where + "a row names the shared fixed body";
          if (isCopy(id) && id != colouring.first_copy)
            return where + "the overflow batch's one piece uses copy " + std::to_string(id);
        }
      }
      continue;
    }
    // Which manifold of the batch last named each body, and from which piece.
    std::unordered_map<int, int> named_by;
    for (int m = begin; m < end; ++m) {
      const auto& manifold = colouring.manifolds[static_cast<std::size_t>(m)];
      const int piece = (m - begin) / colouring.manifolds_per_piece;
      for (const int id : {manifold.body_a, manifold.body_b}) {
        if (id == colouring.fixed_body) return where + "a row names the shared fixed body";
        if (isCopy(id)) {
          if (id != colouring.first_copy + piece)
            return where + "piece " + std::to_string(piece) + " writes fixed-body copy " +
                   std::to_string(id - colouring.first_copy) + ", another piece's";
          continue;
        }
        const bool moving = id < colouring.moving_bodies ||
                            (id >= colouring.first_kinematic && id < colouring.first_copy);
        if (!moving) return where + "a row names solver body " + std::to_string(id) + ", unknown";
        const auto [it, fresh] = named_by.emplace(id, m);
        if (!fresh)
          return where + "manifolds " + std::to_string(it->second) + " and " + std::to_string(m) +
                 " both hold moving body " + std::to_string(id);
      }
    }
  }
  return "";
}

ColouredConstraintSolver::ColouredConstraintSolver(TaskSystem& tasks, int colours)
    : tasks_(tasks), colours_(std::clamp(colours, 0, kColours)), crew_jobs_(tasks.makeGroup()) {}

btScalar ColouredConstraintSolver::solveGroup(btCollisionObject** bodies, int numBodies,
                                              btPersistentManifold** manifolds, int numManifolds,
                                              btTypedConstraint** constraints, int numConstraints,
                                              const btContactSolverInfo& info,
                                              btIDebugDraw* debugDrawer, btDispatcher* dispatcher) {
  TaskCrew crew(tasks_, *crew_jobs_);
  crew_ = &crew;
  struct Release {
    TaskCrew*& crew;
    ~Release() { crew = nullptr; }
  } release{crew_};
  return btSequentialImpulseConstraintSolverMt::solveGroup(
      bodies, numBodies, manifolds, numManifolds, constraints, numConstraints, info, debugDrawer,
      dispatcher);
}

btScalar ColouredConstraintSolver::solveGroupCacheFriendlySetup(
    btCollisionObject** bodies, int numBodies, btPersistentManifold** manifolds, int numManifolds,
    btTypedConstraint** constraints, int numConstraints, const btContactSolverInfo& info,
    btIDebugDraw* debugDrawer) {
  info_ = &info;
  m_numFrictionDirections = (info.m_solverMode & SOLVER_USE_2_FRICTION_DIRECTIONS) ? 2 : 1;
  // Bullet's setup: the bodies, the joints, the contacts (the overrides
  // below), then its order pools.
  return btSequentialImpulseConstraintSolver::solveGroupCacheFriendlySetup(
      bodies, numBodies, manifolds, numManifolds, constraints, numConstraints, info, debugDrawer);
}

// Solver body i is group body i; the shared fixed body comes after them.
void ColouredConstraintSolver::convertBodies(btCollisionObject** bodies, int numBodies,
                                             const btContactSolverInfo& info) {
  m_tmpSolverBodyPool.resizeNoInitialize(numBodies + 1);
  m_fixedBodyId = numBodies;
  initSolverBody(&m_tmpSolverBodyPool[m_fixedBodyId], nullptr, info.m_timeStep);
  crew_->forEachPiece(static_cast<std::size_t>(numBodies), kItemsPerPiece,
                      [this, bodies](std::size_t first, std::size_t end) {
                        internalConvertBodies(bodies, static_cast<int>(first),
                                              static_cast<int>(end), *info_);
                      });
}

void ColouredConstraintSolver::convertJoints(btTypedConstraint** constraints, int numConstraints,
                                             const btContactSolverInfo& info) {
  btSequentialImpulseConstraintSolver::convertJoints(constraints, numConstraints, info);
}

void ColouredConstraintSolver::collectManifolds(btPersistentManifold** manifolds, std::size_t first,
                                                std::size_t end) {
  // Bullet maps every static body to the one fixed solver body; the group's
  // moving bodies have theirs from convertBodies.
  const auto solverBodyOf = [this](const btCollisionObject& object) {
    if (btRigidBody::upcast(&object) == nullptr) return m_fixedBodyId;
    if (object.isKinematicObject()) return kUnconverted;
    if (object.isStaticObject()) return m_fixedBodyId;
    return object.getCompanionId() >= 0 ? object.getCompanionId() : kUnconverted;
  };
  bool unconverted = false;
  for (std::size_t m = first; m < end; ++m) {
    btContactManifoldCachedInfo& cached = m_manifoldCachedInfoArray[static_cast<int>(m)];
    btPersistentManifold& manifold = *manifolds[m];
    cached.solverBodyIds[0] = solverBodyOf(*manifold.getBody0());
    cached.solverBodyIds[1] = solverBodyOf(*manifold.getBody1());
    unconverted = unconverted || cached.solverBodyIds[0] == kUnconverted ||
                  cached.solverBodyIds[1] == kUnconverted;
    int touching = 0;
    for (int p = 0; p < manifold.getNumContacts(); ++p) {
      btManifoldPoint& point = manifold.getContactPoint(p);
      if (point.getDistance() > manifold.getContactProcessingThreshold()) continue;
      cached.contactPoints[touching] = &point;
      cached.contactHasRollingFriction[touching] = point.m_combinedRollingFriction > 0.f;
      ++touching;
    }
    cached.numTouchingContacts = touching;
  }
  if (unconverted) piece_unconverted_[first / kItemsPerPiece] = 1;
}

namespace {

// Bullet's rolling-friction rows of a manifold: three per touching point
// with rolling friction (internalAllocContactConstraints's count).
int rollingRows(const btSequentialImpulseConstraintSolverMt::btContactManifoldCachedInfo& cached) {
  int rows = 0;
  for (int p = 0; p < cached.numTouchingContacts; ++p) {
    if (cached.contactHasRollingFriction[p]) rows += 3;
  }
  return rows;
}

}  // namespace

void ColouredConstraintSolver::colourManifolds(btPersistentManifold** manifolds, int numManifolds,
                                               const btContactSolverInfo& info) {
  const auto count = static_cast<std::size_t>(numManifolds);
  // Kinematic bodies (and any moving body the group left out) get their
  // solver bodies here, in manifold order, as Bullet's serial solver gives them.
  if (std::find(piece_unconverted_.begin(), piece_unconverted_.end(), 1) !=
      piece_unconverted_.end()) {
    for (int m = 0; m < numManifolds; ++m) {
      btContactManifoldCachedInfo& cached = m_manifoldCachedInfoArray[m];
      for (int side = 0; side < 2; ++side) {
        if (cached.solverBodyIds[side] != kUnconverted) continue;
        auto* object = const_cast<btCollisionObject*>(side == 0 ? manifolds[m]->getBody0()
                                                                : manifolds[m]->getBody1());
        cached.solverBodyIds[side] = getOrInitSolverBody(*object, info.m_timeStep);
      }
    }
  }
  const int bodies = m_tmpSolverBodyPool.size();
  colouring_.moving_bodies = m_fixedBodyId;
  colouring_.fixed_body = m_fixedBodyId;
  colouring_.first_kinematic = m_fixedBodyId + 1;
  colouring_.first_copy = bodies;
  colouring_.manifolds_per_piece = kManifoldsPerPiece;

  // Each manifold's rows and colour, in manifold order.
  body_colours_.assign(static_cast<std::size_t>(bodies), 0);
  batch_fill_.assign(kColours + 1, 0);
  colour_rows_.assign(kColours + 1, 0);
  colour_rolling_rows_.assign(kColours + 1, 0);
  colour_.resize(count);
  int used_colours = 0;
  const auto touchesStatic = [&](const btContactManifoldCachedInfo& cached) {
    return cached.solverBodyIds[0] == m_fixedBodyId || cached.solverBodyIds[1] == m_fixedBodyId;
  };
  // The lowest colour from `lowest` on that neither moving body holds.
  const auto colourFrom = [&](int m, int lowest) {
    const btContactManifoldCachedInfo& cached = m_manifoldCachedInfoArray[m];
    const int a = cached.solverBodyIds[0];
    const int b = cached.solverBodyIds[1];
    const std::uint64_t held =
        (a == m_fixedBodyId ? 0 : body_colours_[static_cast<std::size_t>(a)]) |
        (b == m_fixedBodyId ? 0 : body_colours_[static_cast<std::size_t>(b)]);
    const std::uint64_t free = lowest >= kColours ? 0 : ~held & (~std::uint64_t{0} << lowest);
    int colour = kColours;  // the overflow batch
    if (free != 0 && std::countr_zero(free) < colours_) {
      colour = std::countr_zero(free);
      const std::uint64_t bit = std::uint64_t{1} << colour;
      if (a != m_fixedBodyId) body_colours_[static_cast<std::size_t>(a)] |= bit;
      if (b != m_fixedBodyId) body_colours_[static_cast<std::size_t>(b)] |= bit;
      used_colours = std::max(used_colours, colour + 1);
    }
    colour_[static_cast<std::size_t>(m)] = colour;
    ++batch_fill_[static_cast<std::size_t>(colour)];
    colour_rows_[static_cast<std::size_t>(colour)] += cached.numTouchingContacts;
    colour_rolling_rows_[static_cast<std::size_t>(colour)] += rollingRows(cached);
  };
  // Pass 1: the row counts and the manifolds between two moving bodies; pass 2:
  // the manifolds on a static body, in colours after those (so each sweep
  // ends on the walls: physics/coloured_solver.h).
  for (int m = 0; m < numManifolds; ++m) {
    btContactManifoldCachedInfo& cached = m_manifoldCachedInfoArray[m];
    const int a = cached.solverBodyIds[0];
    const int b = cached.solverBodyIds[1];
    // Bullet's serial solver makes no rows between two bodies that cannot move.
    if (m_tmpSolverBodyPool[a].internalGetInvMass().fuzzyZero() &&
        m_tmpSolverBodyPool[b].internalGetInvMass().fuzzyZero()) {
      cached.numTouchingContacts = 0;
    }
    // No rows: any index will do (the rows are laid out below, batch by batch).
    cached.contactIndex = 0;
    cached.rollingFrictionIndex = 0;
    colour_[static_cast<std::size_t>(m)] = -1;
    if (cached.numTouchingContacts > 0 && !touchesStatic(cached)) colourFrom(m, 0);
  }
  const int first_static_colour = used_colours;
  for (int m = 0; m < numManifolds; ++m) {
    const btContactManifoldCachedInfo& cached = m_manifoldCachedInfoArray[m];
    if (cached.numTouchingContacts > 0 && touchesStatic(cached)) {
      colourFrom(m, first_static_colour);
    }
  }

  // The batches: the colours in order (each pass's greedy colouring leaves
  // no colour empty), then the overflow batch if any manifold is in it.
  colouring_.overflow = batch_fill_[kColours] > 0;
  const int batches = used_colours + (colouring_.overflow ? 1 : 0);
  colouring_.batch_begin.resize(static_cast<std::size_t>(batches) + 1);
  int copies = 0;
  int begin = 0;
  int row_begin = 0;
  int rolling_begin = 0;
  for (int batch = 0; batch < batches; ++batch) {
    const int colour = batch < used_colours ? batch : kColours;
    const int size = batch_fill_[static_cast<std::size_t>(colour)];
    colouring_.batch_begin[static_cast<std::size_t>(batch)] = begin;
    batch_fill_[static_cast<std::size_t>(colour)] = begin;  // now the scatter cursor
    // The batch's rows follow the last batch's, so that a sweep walks the
    // row pools from front to back.
    const int batch_rows = colour_rows_[static_cast<std::size_t>(colour)];
    const int batch_rolling_rows = colour_rolling_rows_[static_cast<std::size_t>(colour)];
    colour_rows_[static_cast<std::size_t>(colour)] = row_begin;
    colour_rolling_rows_[static_cast<std::size_t>(colour)] = rolling_begin;
    row_begin += batch_rows;
    rolling_begin += batch_rolling_rows;
    copies = std::max(copies, colour == kColours
                                  ? 1
                                  : static_cast<int>(pieceCount(static_cast<std::size_t>(size),
                                                                kManifoldsPerPiece)));
    begin += size;
  }
  colouring_.batch_begin[static_cast<std::size_t>(batches)] = begin;
  colouring_.copies = copies;
  batches_made_ += batches;

  // Scatter in manifold order; a row against a static body names its
  // piece's copy of the fixed body.
  rows_.resize(static_cast<std::size_t>(begin));
  colouring_.manifolds.resize(static_cast<std::size_t>(begin));
  for (int m = 0; m < numManifolds; ++m) {
    const int colour = colour_[static_cast<std::size_t>(m)];
    if (colour < 0) continue;
    const int position = batch_fill_[static_cast<std::size_t>(colour)]++;
    btContactManifoldCachedInfo& cached = m_manifoldCachedInfoArray[m];
    cached.contactIndex = colour_rows_[static_cast<std::size_t>(colour)];
    colour_rows_[static_cast<std::size_t>(colour)] += cached.numTouchingContacts;
    cached.rollingFrictionIndex = colour_rolling_rows_[static_cast<std::size_t>(colour)];
    colour_rolling_rows_[static_cast<std::size_t>(colour)] += rollingRows(cached);
    const int batch = colour == kColours ? batches - 1 : colour;
    const int piece = colour == kColours
                          ? 0
                          : (position - colouring_.batch_begin[static_cast<std::size_t>(batch)]) /
                                kManifoldsPerPiece;
    for (int& id : cached.solverBodyIds) {
      if (id == m_fixedBodyId) id = colouring_.first_copy + piece;
    }
    rows_[static_cast<std::size_t>(position)] = {cached.contactIndex, cached.numTouchingContacts};
    colouring_.manifolds[static_cast<std::size_t>(position)] = {cached.solverBodyIds[0],
                                                                cached.solverBodyIds[1]};
  }
  for (int copy = 0; copy < copies; ++copy) {
    initSolverBody(&m_tmpSolverBodyPool.expand(), nullptr, info.m_timeStep);
  }
  piece_residual_.resize(static_cast<std::size_t>(std::max(copies, 1)));
  // Every manifold with rows has a colour, so the batches hold them all.
  sizeRowPools(row_begin, rolling_begin);
}

void ColouredConstraintSolver::sizeRowPools(int contacts, int rolling_rows) {
  if (m_tmpSolverContactConstraintPool.capacity() < contacts) {
    const int spare = contacts / 16;
    m_tmpSolverContactConstraintPool.reserve(contacts + spare);
    m_rollingFrictionIndexTable.reserve(contacts + spare);
    m_tmpSolverContactFrictionConstraintPool.reserve((contacts + spare) * m_numFrictionDirections);
  }
  if (m_tmpSolverContactRollingFrictionConstraintPool.capacity() < rolling_rows) {
    m_tmpSolverContactRollingFrictionConstraintPool.reserve(rolling_rows + rolling_rows / 16);
  }
  m_tmpSolverContactConstraintPool.resizeNoInitialize(contacts);
  m_rollingFrictionIndexTable.resizeNoInitialize(contacts);
  m_tmpSolverContactFrictionConstraintPool.resizeNoInitialize(contacts * m_numFrictionDirections);
  m_tmpSolverContactRollingFrictionConstraintPool.resizeNoInitialize(rolling_rows);
}

void ColouredConstraintSolver::convertContacts(btPersistentManifold** manifolds, int numManifolds,
                                               const btContactSolverInfo& info) {
  const auto count = static_cast<std::size_t>(numManifolds);
  if (m_manifoldCachedInfoArray.capacity() < numManifolds) {
    m_manifoldCachedInfoArray.reserve(numManifolds + numManifolds / 16);
  }
  m_manifoldCachedInfoArray.resizeNoInitialize(numManifolds);
  piece_unconverted_.assign(pieceCount(count, kItemsPerPiece), 0);
  crew_->forEachPiece(count, kItemsPerPiece, [this, manifolds](std::size_t first, std::size_t end) {
    collectManifolds(manifolds, first, end);
  });
  colourManifolds(manifolds, numManifolds, info);
  // Each manifold writes its own rows (Bullet's allocation, by manifold).
  crew_->forEachPiece(count, kItemsPerPiece, [this](std::size_t first, std::size_t end) {
    internalAllocContactConstraints(&m_manifoldCachedInfoArray[static_cast<int>(first)],
                                    static_cast<int>(end - first));
  });
  // The setup applies the warm-start impulses to the bodies: by colour.
  sweep([this](int contact) {
    internalSetupContactConstraints(contact, *info_);
    return btScalar(0);
  });
}

template <typename Row>
btScalar ColouredConstraintSolver::sweepBatch(int batch, const Row& row) {
  const auto b = static_cast<std::size_t>(batch);
  const int begin = colouring_.batch_begin[b];
  const auto count = static_cast<std::size_t>(colouring_.batch_begin[b + 1] - begin);
  const bool overflow = colouring_.overflow && batch == colouring_.batches() - 1;
  // The overflow batch may touch a body twice: one piece, in manifold order.
  const std::size_t grain = overflow ? count : static_cast<std::size_t>(kManifoldsPerPiece);
  // One pointer captured: the loop body fits in std::function's own storage.
  struct Sweep {
    ColouredConstraintSolver* solver;
    const Row* row;
    int begin;
    std::size_t grain;
  };
  const Sweep context{this, &row, begin, grain};
  crew_->forEachPiece(count, grain, [&context](std::size_t first, std::size_t end) {
    const RowRange* ranges = context.solver->rows_.data() + context.begin;
    btScalar worst = 0;
    for (std::size_t m = first; m < end; ++m) {
      for (int contact = ranges[m].first, last = ranges[m].first + ranges[m].rows; contact < last;
           ++contact) {
        worst = btMax(worst, (*context.row)(contact));
      }
    }
    context.solver->piece_residual_[first / context.grain] = worst;
  });
  btScalar worst = 0;
  for (std::size_t piece = 0, pieces = pieceCount(count, grain); piece < pieces; ++piece) {
    worst = btMax(worst, piece_residual_[piece]);
  }
  return worst;
}

template <typename Row>
btScalar ColouredConstraintSolver::sweep(const Row& row) {
  btScalar worst = 0;
  for (int batch = 0; batch < colouring_.batches(); ++batch) {
    worst = btMax(worst, sweepBatch(batch, row));
  }
  return worst;
}

btScalar ColouredConstraintSolver::solveContactRow(int contact) {
  const btSolverConstraint& row = m_tmpSolverContactConstraintPool[contact];
  const btScalar residual = resolveSingleConstraintRowLowerLimit(
      m_tmpSolverBodyPool[row.m_solverBodyIdA], m_tmpSolverBodyPool[row.m_solverBodyIdB], row);
  return residual * residual;
}

// Bullet's friction rows of one contact, bounded by its normal impulse.
btScalar ColouredConstraintSolver::solveFrictionRows(int contact) {
  const btScalar total = m_tmpSolverContactConstraintPool[contact].m_appliedImpulse;
  if (!(total > btScalar(0))) return 0;
  btScalar worst = 0;
  for (int f = contact * m_numFrictionDirections, end = f + m_numFrictionDirections; f < end; ++f) {
    btSolverConstraint& row = m_tmpSolverContactFrictionConstraintPool[f];
    row.m_lowerLimit = -(row.m_friction * total);
    row.m_upperLimit = row.m_friction * total;
    const btScalar residual = resolveSingleConstraintRowGeneric(
        m_tmpSolverBodyPool[row.m_solverBodyIdA], m_tmpSolverBodyPool[row.m_solverBodyIdB], row);
    worst = btMax(worst, residual * residual);
  }
  return worst;
}

// Bullet's rolling-friction rows of one contact (up to three, allocated by
// internalAllocContactConstraints; a disabled one ends them).
btScalar ColouredConstraintSolver::solveRollingFrictionRows(int contact) {
  const int first = m_rollingFrictionIndexTable[contact];
  if (first < 0) return 0;
  const btScalar total = m_tmpSolverContactConstraintPool[contact].m_appliedImpulse;
  if (!(total > btScalar(0))) return 0;
  btScalar worst = 0;
  for (int r = first; r < first + 3; ++r) {
    btSolverConstraint& row = m_tmpSolverContactRollingFrictionConstraintPool[r];
    if (row.m_frictionIndex != contact) break;
    const btScalar magnitude = std::min(row.m_friction * total, row.m_friction);
    row.m_lowerLimit = -magnitude;
    row.m_upperLimit = magnitude;
    const btScalar residual = resolveSingleConstraintRowGeneric(
        m_tmpSolverBodyPool[row.m_solverBodyIdA], m_tmpSolverBodyPool[row.m_solverBodyIdB], row);
    worst = btMax(worst, residual * residual);
  }
  return worst;
}

void ColouredConstraintSolver::solveGroupCacheFriendlySplitImpulseIterations(
    btCollisionObject** /*bodies*/, int /*numBodies*/, btPersistentManifold** /*manifolds*/,
    int /*numManifolds*/, btTypedConstraint** /*constraints*/, int /*numConstraints*/,
    const btContactSolverInfo& info, btIDebugDraw* /*debugDrawer*/) {
  if (!info.m_splitImpulse) return;
  for (int iteration = 0; iteration < info.m_numIterations; ++iteration) {
    const btScalar worst = sweep([this](int contact) {
      const btSolverConstraint& row = m_tmpSolverContactConstraintPool[contact];
      const btScalar residual = resolveSplitPenetrationImpulse(
          m_tmpSolverBodyPool[row.m_solverBodyIdA], m_tmpSolverBodyPool[row.m_solverBodyIdB], row);
      return residual * residual;
    });
    if (worst <= info.m_leastSquaresResidualThreshold || iteration >= info.m_numIterations - 1) {
      break;
    }
  }
}

btScalar ColouredConstraintSolver::solveSingleIteration(
    int iteration, btCollisionObject** /*bodies*/, int /*numBodies*/,
    btPersistentManifold** /*manifolds*/, int /*numManifolds*/, btTypedConstraint** constraints,
    int numConstraints, const btContactSolverInfo& info, btIDebugDraw* /*debugDrawer*/) {
  btScalar worst = 0;
  // The joints, serially, as Bullet's serial solver sweeps them.
  for (int j = 0; j < m_tmpSolverNonContactConstraintPool.size(); ++j) {
    btSolverConstraint& row =
        m_tmpSolverNonContactConstraintPool[m_orderNonContactConstraintPool[j]];
    if (iteration < row.m_overrideNumSolverIterations) {
      const btScalar residual = resolveSingleConstraintRowGeneric(
          m_tmpSolverBodyPool[row.m_solverBodyIdA], m_tmpSolverBodyPool[row.m_solverBodyIdB], row);
      worst = btMax(worst, residual * residual);
    }
  }
  if (iteration >= info.m_numIterations) return worst;
  for (int j = 0; j < numConstraints; ++j) {
    if (!constraints[j]->isEnabled()) continue;
    const int a = getOrInitSolverBody(constraints[j]->getRigidBodyA(), info.m_timeStep);
    const int b = getOrInitSolverBody(constraints[j]->getRigidBodyB(), info.m_timeStep);
    constraints[j]->solveConstraintObsolete(m_tmpSolverBodyPool[a], m_tmpSolverBodyPool[b],
                                            info.m_timeStep);
  }
  if (info.m_solverMode & SOLVER_INTERLEAVE_CONTACT_AND_FRICTION_CONSTRAINTS) {
    return btMax(worst, sweep([this](int contact) {
                   // The contact's normal row first: its impulse bounds the friction.
                   const btScalar normal = solveContactRow(contact);
                   const btScalar friction = solveFrictionRows(contact);
                   return btMax(normal, btMax(friction, solveRollingFrictionRows(contact)));
                 }));
  }
  worst = btMax(worst, sweep([this](int contact) { return solveContactRow(contact); }));
  worst = btMax(worst, sweep([this](int contact) { return solveFrictionRows(contact); }));
  if (m_tmpSolverContactRollingFrictionConstraintPool.size() > 0) {
    worst = btMax(worst, sweep([this](int contact) { return solveRollingFrictionRows(contact); }));
  }
  return worst;
}

btScalar ColouredConstraintSolver::solveGroupCacheFriendlyFinish(btCollisionObject** /*bodies*/,
                                                                 int /*numBodies*/,
                                                                 const btContactSolverInfo& info) {
  // Each contact writes its own point, each solver body its own body.
  if (info.m_solverMode & SOLVER_USE_WARMSTARTING) {
    crew_->forEachPiece(static_cast<std::size_t>(m_tmpSolverContactConstraintPool.size()),
                        kItemsPerPiece, [this](std::size_t first, std::size_t end) {
                          writeBackContacts(static_cast<int>(first), static_cast<int>(end), *info_);
                        });
  }
  writeBackJoints(0, m_tmpSolverNonContactConstraintPool.size(), info);
  crew_->forEachPiece(static_cast<std::size_t>(m_tmpSolverBodyPool.size()), kItemsPerPiece,
                      [this](std::size_t first, std::size_t end) {
                        writeBackBodies(static_cast<int>(first), static_cast<int>(end), *info_);
                      });
  m_tmpSolverContactConstraintPool.resizeNoInitialize(0);
  m_tmpSolverNonContactConstraintPool.resizeNoInitialize(0);
  m_tmpSolverContactFrictionConstraintPool.resizeNoInitialize(0);
  m_tmpSolverContactRollingFrictionConstraintPool.resizeNoInitialize(0);
  m_tmpSolverBodyPool.resizeNoInitialize(0);
  return 0;
}

std::unique_ptr<btConstraintSolver> makeConstraintSolver(SolverOrder order, TaskSystem& tasks) {
  if (order == SolverOrder::kSerial) return std::make_unique<btSequentialImpulseConstraintSolver>();
  return std::make_unique<ColouredConstraintSolver>(tasks);
}

}  // namespace overlap::physics
