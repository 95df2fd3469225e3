#include "physics/coloured_solver.h"

#include <BulletCollision/NarrowPhaseCollision/btPersistentManifold.h>
#include <BulletDynamics/ConstraintSolver/btTypedConstraint.h>
#include <BulletDynamics/Dynamics/btRigidBody.h>

#include <algorithm>
#include <array>
#include <bit>
#include <unordered_map>
#include <utility>

namespace overlap::physics {
namespace {

constexpr int kUnconverted = -1;  // a body only the serial pass may convert
constexpr int kPending = -2;      // a manifold's bucket, until its bodies are converted

// A sweep's range function of row(contact), for each contact in order: the
// largest of its results.
template <typename Row>
auto eachContact(Row row) {
  return [row](int first, int end) {
    btScalar worst = 0;
    for (int contact = first; contact < end; ++contact) worst = btMax(worst, row(contact));
    return worst;
  };
}

}  // namespace

std::string batchProblem(const ContactBatches& batches) {
  const auto isCopy = [&](int id) {
    return id >= batches.first_copy && id < batches.first_copy + batches.copies;
  };
  const auto pieces = static_cast<int>(batches.piece_begin.size()) - 1;
  if (batches.batches() > 0 &&
      (batches.batch_piece.front() != 0 || batches.batch_piece.back() != pieces ||
       batches.piece_begin.front() != 0 ||
       batches.piece_begin.back() != static_cast<int>(batches.manifolds.size()) ||
       !std::is_sorted(batches.batch_piece.begin(), batches.batch_piece.end()) ||
       !std::is_sorted(batches.piece_begin.begin(), batches.piece_begin.end()))) {
    return "the batches' pieces do not cover the manifolds in order";
  }
  for (int batch = 0; batch < batches.batches(); ++batch) {
    const int first_piece = batches.batch_piece[static_cast<std::size_t>(batch)];
    const int end_piece = batches.batch_piece[static_cast<std::size_t>(batch) + 1];
    const std::string where = "batch " + std::to_string(batch) + ": ";
    // Which piece of the batch named each moving body (a piece is serial: it
    // may name a body more than once).
    std::unordered_map<int, int> named_by;
    for (int piece = first_piece; piece < end_piece; ++piece) {
      const int k = piece - first_piece;  // the piece's place in its batch
      for (int m = batches.piece_begin[static_cast<std::size_t>(piece)];
           m < batches.piece_begin[static_cast<std::size_t>(piece) + 1]; ++m) {
        const auto& manifold = batches.manifolds[static_cast<std::size_t>(m)];
        for (const int id : {manifold.body_a, manifold.body_b}) {
          if (id == batches.fixed_body) return where + "a row names the shared fixed body";
          if (isCopy(id)) {
            if (id != batches.first_copy + k)
              return where + "piece " + std::to_string(k) + " writes fixed-body copy " +
                     std::to_string(id - batches.first_copy) + ", another piece's";
            continue;
          }
          const bool moving = id < batches.moving_bodies ||
                              (id >= batches.first_kinematic && id < batches.first_copy);
          if (!moving) return where + "a row names solver body " + std::to_string(id) + ", unknown";
          const auto [it, fresh] = named_by.emplace(id, k);
          if (!fresh && it->second != k)
            return where + "pieces " + std::to_string(it->second) + " and " + std::to_string(k) +
                   " both hold moving body " + std::to_string(id);
        }
      }
    }
  }
  return "";
}

ColouredConstraintSolver::ColouredConstraintSolver(TaskSystem& tasks, Split split)
    : tasks_(tasks), split_(split), crew_jobs_(tasks.makeGroup()) {}

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

// The solver bodies are the group's, region after region (each region's in
// the group's order), then the shared fixed body.
void ColouredConstraintSolver::convertBodies(btCollisionObject** bodies, int numBodies,
                                             const btContactSolverInfo& info) {
  m_tmpSolverBodyPool.resizeNoInitialize(numBodies + 1);
  m_fixedBodyId = numBodies;
  initSolverBody(&m_tmpSolverBodyPool[m_fixedBodyId], nullptr, info.m_timeStep);
  batches_.regions = split_ == Split::kRegions ? splitRegions(bodies, numBodies) : 0;
  if (batches_.regions == 0) body_region_.clear();
  btCollisionObject** ordered = batches_.regions > 0 ? solver_bodies_.data() : bodies;
  crew_->forEachPiece(static_cast<std::size_t>(numBodies), kItemsPerPiece,
                      [this, ordered](std::size_t first, std::size_t end) {
                        internalConvertBodies(ordered, static_cast<int>(first),
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
    bucket_[m] = kPending;
    const int a = cached.solverBodyIds[0];
    const int b = cached.solverBodyIds[1];
    if (a != kUnconverted && b != kUnconverted) classify(static_cast<int>(m));
  }
  const std::size_t piece = first / kItemsPerPiece;
  if (unconverted) {
    piece_unconverted_[piece] = 1;  // counted once the serial pass has classified it
  } else {
    countPiece(piece, first, end);
  }
}

void ColouredConstraintSolver::classify(int m) {
  btContactManifoldCachedInfo& cached = m_manifoldCachedInfoArray[m];
  const int a = cached.solverBodyIds[0];
  const int b = cached.solverBodyIds[1];
  // Bullet's serial solver makes no rows between two bodies that cannot move.
  if (m_tmpSolverBodyPool[a].internalGetInvMass().fuzzyZero() &&
      m_tmpSolverBodyPool[b].internalGetInvMass().fuzzyZero()) {
    cached.numTouchingContacts = 0;
  }
  // No rows: any index will do (the rows are laid out piece by piece).
  cached.contactIndex = 0;
  cached.rollingFrictionIndex = 0;
  bucket_[static_cast<std::size_t>(m)] = cached.numTouchingContacts > 0 ? bucketOf(a, b) : -1;
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

namespace {

// A float's place in IEEE-754's total order, as an integer (NaNs included),
// so that a comparison on it is a strict weak order for any position.
std::int32_t totalOrderKey(btScalar value) {
  const auto bits = std::bit_cast<std::int32_t>(value);
  return bits < 0 ? bits ^ 0x7fffffff : bits;
}

}  // namespace

int ColouredConstraintSolver::splitRegions(btCollisionObject** bodies, int numBodies) {
  const auto moving = static_cast<std::size_t>(numBodies);
  region_keys_.resize(moving);
  // A body's position as initSolverBody gives its solver body.
  crew_->forEachPiece(moving, kItemsPerPiece, [this, bodies](std::size_t first, std::size_t end) {
    for (std::size_t i = first; i < end; ++i) {
      const btVector3 origin = btRigidBody::upcast(bodies[i]) != nullptr
                                   ? bodies[i]->getWorldTransform().getOrigin()
                                   : btVector3(0, 0, 0);
      region_keys_[i] = {
          origin,
          {totalOrderKey(origin.x()), totalOrderKey(origin.y()), totalOrderKey(origin.z())},
          static_cast<int>(i)};
    }
  });
  // Level after level, each part halved at the median of its widest axis,
  // the parts of a level in parallel (each writes only its own keys).
  part_begin_.assign({0, numBodies});
  // As many halvings as leave kBodiesPerRegion bodies a region or more, up
  // to kRegionLevels: a smaller pile's regions would be a few boxes each.
  int levels = 0;
  while (levels < kRegionLevels && (numBodies >> (levels + 1)) >= kBodiesPerRegion) ++levels;
  const int regions = 1 << levels;
  for (int level = 0; level < levels; ++level) {
    const std::size_t parts = part_begin_.size() - 1;
    crew_->forEachPiece(parts, 1, [this](std::size_t first, std::size_t end) {
      for (std::size_t part = first; part < end; ++part) {
        const auto begin = region_keys_.begin() + part_begin_[part];
        const auto stop = region_keys_.begin() + part_begin_[part + 1];
        if (stop - begin < 2) continue;
        btVector3 low(BT_LARGE_FLOAT, BT_LARGE_FLOAT, BT_LARGE_FLOAT);
        btVector3 high = -low;
        for (auto key = begin; key != stop; ++key) {
          low.setMin(key->origin);
          high.setMax(key->origin);
        }
        const int axis = (high - low).maxAxis();
        std::nth_element(begin, begin + (stop - begin) / 2, stop,
                         [axis](const RegionKey& x, const RegionKey& y) {
                           return x.key[axis] < y.key[axis] ||
                                  (x.key[axis] == y.key[axis] && x.body < y.body);
                         });
      }
    });
    std::vector<int>& halves = part_halves_;
    halves.clear();
    for (std::size_t part = 0; part < parts; ++part) {
      const int lo = part_begin_[part];
      halves.push_back(lo);
      halves.push_back(lo + (part_begin_[part + 1] - lo) / 2);
    }
    halves.push_back(numBodies);
    std::swap(part_begin_, halves);
  }
  // Part p is region p << (kRegionLevels - levels): the splits not made
  // leave no manifold across them.  Its bodies, in the group's order, take
  // the solver bodies after the earlier parts'.
  solver_bodies_.resize(moving);
  body_region_.resize(moving);
  crew_->forEachPiece(
      static_cast<std::size_t>(regions), 1,
      [this, bodies, levels](std::size_t first, std::size_t end) {
        for (std::size_t part = first; part < end; ++part) {
          const int begin = part_begin_[part];
          const int stop = part_begin_[part + 1];
          std::sort(region_keys_.begin() + begin, region_keys_.begin() + stop,
                    [](const RegionKey& x, const RegionKey& y) { return x.body < y.body; });
          for (int id = begin; id < stop; ++id) {
            const auto i = static_cast<std::size_t>(id);
            solver_bodies_[i] = bodies[region_keys_[i].body];
            body_region_[i] = static_cast<int>(part) << (kRegionLevels - levels);
          }
        }
      });
  return regions;
}

void ColouredConstraintSolver::countPiece(std::size_t piece, std::size_t first, std::size_t end) {
  BucketCount* counts = piece_counts_.data() + piece * kBuckets;
  std::fill(counts, counts + kBuckets, BucketCount{});
  for (std::size_t m = first; m < end; ++m) {
    const int bucket = bucket_[m];
    if (bucket < 0) continue;
    const btContactManifoldCachedInfo& cached = m_manifoldCachedInfoArray[static_cast<int>(m)];
    BucketCount& count = counts[bucket];
    ++count.manifolds;
    count.rows += cached.numTouchingContacts;
    count.rolling_rows += rollingRows(cached);
  }
}

int ColouredConstraintSolver::bucketOf(int a, int b) const {
  if (split_ == Split::kNone) return 0;
  const auto regionOf = [&](int id) {
    return id < m_fixedBodyId ? body_region_[static_cast<std::size_t>(id)] : -1;
  };
  if (a == m_fixedBodyId || b == m_fixedBodyId) {
    const int region = regionOf(a == m_fixedBodyId ? b : a);
    return region >= 0 ? kFirstWallBucket + region : kSerialBucket;
  }
  const int region_a = regionOf(a);
  const int region_b = regionOf(b);
  if (region_a < 0 || region_b < 0) return kSerialBucket;  // kinematic: one piece
  if (region_a == region_b) return region_a;
  // The first split between them (region bit kRegionLevels - 1 - level), and
  // the part of the regions it halved.
  const int level = kRegionLevels - std::bit_width(static_cast<unsigned>(region_a ^ region_b));
  const int low = std::min(region_a, region_b);
  const int high = std::max(region_a, region_b);
  const int part = low >> (kRegionLevels - level);
  if (level == kRegionLevels - 1) return acrossFirstBucket(level, false) + part;
  // The halves' next split: the pieces of a batch share no body.
  const int next_bit = kRegionLevels - 2 - level;
  const int low_side = (low >> next_bit) & 1;
  const int high_side = (high >> next_bit) & 1;
  return acrossFirstBucket(level, low_side != high_side) + (part << 1) + low_side;
}

void ColouredConstraintSolver::batchManifolds(btPersistentManifold** manifolds, int numManifolds,
                                              const btContactSolverInfo& info) {
  // Kinematic bodies (and any moving body the group left out) get their
  // solver bodies here, in manifold order, as Bullet's serial solver gives them.
  const auto count = static_cast<std::size_t>(numManifolds);
  const std::size_t pieces = pieceCount(count, kItemsPerPiece);
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
      if (bucket_[static_cast<std::size_t>(m)] == kPending) classify(m);
    }
    for (std::size_t piece = 0; piece < pieces; ++piece) {
      if (piece_unconverted_[piece] == 0) continue;
      countPiece(piece, piece * kItemsPerPiece, std::min(count, (piece + 1) * kItemsPerPiece));
    }
  }
  const int bodies = m_tmpSolverBodyPool.size();
  batches_.moving_bodies = m_fixedBodyId;
  batches_.fixed_body = m_fixedBodyId;
  batches_.first_kinematic = m_fixedBodyId + 1;
  batches_.first_copy = bodies;
  const bool split = split_ == Split::kRegions;
  const int buckets = split ? kBuckets : 1;

  bucket_counts_.assign(static_cast<std::size_t>(buckets), BucketCount{});
  for (std::size_t piece = 0; piece < pieces; ++piece) {
    const BucketCount* counts = piece_counts_.data() + piece * kBuckets;
    for (int bucket = 0; bucket < buckets; ++bucket) {
      bucket_counts_[static_cast<std::size_t>(bucket)].add(counts[bucket]);
    }
  }

  // The batches: runs of buckets, each bucket a piece, a batch with no
  // manifold left out.  Each bucket's manifolds and rows follow the last
  // bucket's, so that a sweep walks the row pools from front to back; the
  // bucket counts become the buckets' starts.
  std::vector<int>& piece_begin = batches_.piece_begin;
  std::vector<int>& batch_piece = batches_.batch_piece;
  piece_begin.clear();
  batch_piece.clear();
  piece_rows_.clear();
  batch_of_bucket_.assign(static_cast<std::size_t>(buckets), 0);
  int position = 0;
  int row_begin = 0;
  int rolling_begin = 0;
  int copies = 0;
  const auto addBatch = [&](int first_bucket, int end_bucket) {
    int size = 0;
    for (int bucket = first_bucket; bucket < end_bucket; ++bucket) {
      size += bucket_counts_[static_cast<std::size_t>(bucket)].manifolds;
    }
    if (size == 0) return;
    batch_piece.push_back(static_cast<int>(piece_begin.size()));
    for (int bucket = first_bucket; bucket < end_bucket; ++bucket) {
      const auto i = static_cast<std::size_t>(bucket);
      batch_of_bucket_[i] = first_bucket;
      piece_begin.push_back(position);
      piece_rows_.push_back(row_begin);
      BucketCount& total = bucket_counts_[i];
      position += std::exchange(total.manifolds, position);
      row_begin += std::exchange(total.rows, row_begin);
      rolling_begin += std::exchange(total.rolling_rows, rolling_begin);
    }
    copies = std::max(copies, end_bucket - first_bucket);
  };
  if (split) {
    addBatch(0, kRegions);
    addBatch(acrossFirstBucket(kRegionLevels - 1, false),
             acrossFirstBucket(kRegionLevels - 2, false));
    for (int level = kRegionLevels - 2; level >= 0; --level) {
      for (const bool crossed : {false, true}) {
        const int first = acrossFirstBucket(level, crossed);
        addBatch(first, first + (2 << level));
      }
    }
    addBatch(kSerialBucket, kSerialBucket + 1);
    addBatch(kFirstWallBucket, kFirstWallBucket + kRegions);
  } else {
    addBatch(0, 1);
  }
  batch_piece.push_back(static_cast<int>(piece_begin.size()));
  piece_begin.push_back(position);
  piece_rows_.push_back(row_begin);
  batches_.copies = copies;
  batches_made_ += batches_.batches();

  // Each collect piece's cursors: its bucket's start, after the earlier
  // pieces' manifolds and rows there.
  for (int bucket = 0; bucket < buckets; ++bucket) {
    BucketCount next = bucket_counts_[static_cast<std::size_t>(bucket)];
    for (std::size_t piece = 0; piece < pieces; ++piece) {
      BucketCount& counts = piece_counts_[piece * kBuckets + static_cast<std::size_t>(bucket)];
      next.add(std::exchange(counts, next));
    }
  }
  batches_.manifolds.resize(static_cast<std::size_t>(position));
  crew_->forEachPiece(count, kItemsPerPiece, [this](std::size_t first, std::size_t end) {
    scatterPiece(first / kItemsPerPiece, first, end);
  });
  for (int copy = 0; copy < copies; ++copy) {
    initSolverBody(&m_tmpSolverBodyPool.expand(), nullptr, info.m_timeStep);
  }
  piece_residual_.resize(static_cast<std::size_t>(std::max(copies, 1)));
  sizeRowPools(row_begin, rolling_begin);
}

// A row against a static body names its piece's copy of the fixed body
// (the piece's place in its batch).
void ColouredConstraintSolver::scatterPiece(std::size_t piece, std::size_t first, std::size_t end) {
  BucketCount* cursors = piece_counts_.data() + piece * kBuckets;
  for (std::size_t m = first; m < end; ++m) {
    const int bucket = bucket_[m];
    if (bucket < 0) continue;
    BucketCount& cursor = cursors[bucket];
    btContactManifoldCachedInfo& cached = m_manifoldCachedInfoArray[static_cast<int>(m)];
    const auto place = static_cast<std::size_t>(cursor.manifolds++);
    cached.contactIndex = cursor.rows;
    cursor.rows += cached.numTouchingContacts;
    cached.rollingFrictionIndex = cursor.rolling_rows;
    cursor.rolling_rows += rollingRows(cached);
    const int copy = bucket - batch_of_bucket_[static_cast<std::size_t>(bucket)];
    for (int& id : cached.solverBodyIds) {
      if (id == m_fixedBodyId) id = batches_.first_copy + copy;
    }
    batches_.manifolds[place] = {cached.solverBodyIds[0], cached.solverBodyIds[1]};
  }
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
  piece_counts_.resize(pieceCount(count, kItemsPerPiece) * kBuckets);
  // The joints' and kinematic bodies' solver bodies (after the fixed one)
  // are in no region.
  body_region_.resize(static_cast<std::size_t>(m_tmpSolverBodyPool.size()), -1);
  bucket_.resize(count);
  crew_->forEachPiece(count, kItemsPerPiece, [this, manifolds](std::size_t first, std::size_t end) {
    collectManifolds(manifolds, first, end);
  });
  batchManifolds(manifolds, numManifolds, info);
  // Each manifold writes its own rows (Bullet's allocation, by manifold).
  crew_->forEachPiece(count, kItemsPerPiece, [this](std::size_t first, std::size_t end) {
    internalAllocContactConstraints(&m_manifoldCachedInfoArray[static_cast<int>(first)],
                                    static_cast<int>(end - first));
  });
  // The setup applies the warm-start impulses to the bodies: batch by batch.
  sweep(eachContact([this](int contact) {
    internalSetupContactConstraints(contact, *info_);
    return btScalar(0);
  }));
}

template <typename Rows>
btScalar ColouredConstraintSolver::sweepBatch(int batch, const Rows& rows) {
  const auto b = static_cast<std::size_t>(batch);
  const int first_piece = batches_.batch_piece[b];
  const auto pieces = static_cast<std::size_t>(batches_.batch_piece[b + 1] - first_piece);
  // Pointers captured: the loop body fits in std::function's own storage.
  struct Sweep {
    btScalar* residual;
    const Rows* rows;
    const int* piece_rows;  // the batch's first piece's
  };
  const Sweep context{piece_residual_.data(), &rows, piece_rows_.data() + first_piece};
  crew_->forEachPiece(pieces, 1, [&context](std::size_t first, std::size_t end) {
    for (std::size_t piece = first; piece < end; ++piece) {
      context.residual[piece] =
          (*context.rows)(context.piece_rows[piece], context.piece_rows[piece + 1]);
    }
  });
  btScalar worst = 0;
  for (std::size_t piece = 0; piece < pieces; ++piece) worst = btMax(worst, piece_residual_[piece]);
  return worst;
}

template <typename Rows>
btScalar ColouredConstraintSolver::sweep(const Rows& rows) {
  btScalar worst = 0;
  for (int batch = 0; batch < batches_.batches(); ++batch) {
    worst = btMax(worst, sweepBatch(batch, rows));
  }
  return worst;
}

// The hot loops call Bullet's row function through the pointer that its
// resolve... members call, with the pools' bases read once.
btScalar ColouredConstraintSolver::solveContactRows(int first, int end,
                                                    btSingleConstraintRowSolver solve) {
  if (first == end) return 0;
  btSolverBody* const bodies = &m_tmpSolverBodyPool[0];
  const btSolverConstraint* const rows = &m_tmpSolverContactConstraintPool[0];
  btScalar worst = 0;
  for (int contact = first; contact < end; ++contact) {
    const btSolverConstraint& row = rows[contact];
    const btScalar residual = solve(bodies[row.m_solverBodyIdA], bodies[row.m_solverBodyIdB], row);
    worst = btMax(worst, residual * residual);
  }
  return worst;
}

btScalar ColouredConstraintSolver::solveFrictionRows(int first, int end) {
  if (first == end) return 0;
  btSolverBody* const bodies = &m_tmpSolverBodyPool[0];
  const btSolverConstraint* const contacts = &m_tmpSolverContactConstraintPool[0];
  btSolverConstraint* const rows = &m_tmpSolverContactFrictionConstraintPool[0];
  const int directions = m_numFrictionDirections;
  const btSingleConstraintRowSolver solve = m_resolveSingleConstraintRowGeneric;
  btScalar worst = 0;
  for (int contact = first; contact < end; ++contact) {
    // Bounded by the contact's normal impulse.
    const btScalar total = contacts[contact].m_appliedImpulse;
    if (!(total > btScalar(0))) continue;
    for (int f = contact * directions, last = f + directions; f < last; ++f) {
      btSolverConstraint& row = rows[f];
      row.m_lowerLimit = -(row.m_friction * total);
      row.m_upperLimit = row.m_friction * total;
      const btScalar residual =
          solve(bodies[row.m_solverBodyIdA], bodies[row.m_solverBodyIdB], row);
      worst = btMax(worst, residual * residual);
    }
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
    const btScalar worst = sweep([this](int first, int end) {
      return solveContactRows(first, end, m_resolveSplitPenetrationImpulse);
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
    return btMax(worst, sweep(eachContact([this](int contact) {
                   // The contact's normal row first: its impulse bounds the friction.
                   const btScalar normal = solveContactRows(contact, contact + 1,
                                                            m_resolveSingleConstraintRowLowerLimit);
                   const btScalar friction = solveFrictionRows(contact, contact + 1);
                   return btMax(normal, btMax(friction, solveRollingFrictionRows(contact)));
                 })));
  }
  worst = btMax(worst, sweep([this](int first, int end) {
                  return solveContactRows(first, end, m_resolveSingleConstraintRowLowerLimit);
                }));
  worst = btMax(worst, sweep([this](int first, int end) { return solveFrictionRows(first, end); }));
  if (m_tmpSolverContactRollingFrictionConstraintPool.size() > 0) {
    worst = btMax(
        worst,
        sweep(eachContact([this](int contact) { return solveRollingFrictionRows(contact); })));
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
