#include "engine/streams/stream_generator.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "gpu/base/interrupt.h"
#include "gpu/base/random.h"
#include "physics/step_policy.h"

namespace overlap::engine {
namespace {

using Eigen::Vector3d;

// A random pile of boxes fills about this share of its volume; the pressure
// acts above it.
constexpr double kPileDensity = 0.5;
// The pressure's stiffness: the deepest pile is squeezed about this much
// beyond kPileDensity.
constexpr double kSqueeze = 0.05;
// Grid cells this many times the cube root of the mean box volume: enough
// boxes per cell that their count is smooth, and a pile that moves as a few
// large blocks, as Bullet's does (smaller cells make it flow like a liquid,
// its boxes changing partners two to three times as often).
constexpr double kCellInBoxes = 4.0;
// Substeps: a pressure wave crosses at most this share of a cell per substep.
constexpr double kCourant = 0.4;
constexpr int kMaxCellsPerAxis = 256;
// Friction: with the walls (Coulomb), and inside a pile (a damping rate, 1/s),
// where the pile's density passes this share of kPileDensity.
constexpr double kWallFriction = 0.5;
constexpr double kPileDamping = 6.0;
constexpr double kInPile = 0.4;
// Rounds of averaging the pile's velocity with the neighbouring cells'.
constexpr int kSmoothingRounds = 2;
// A box spins at this share of its speed over its half edge (rolling-ish).
constexpr double kSpin = 0.5;
// Bullet's sleeping: slower than 0.8 m/s for 2 s.
constexpr double kSleepSpeed = 0.8;
constexpr double kSleepSeconds = 2.0;
// Volumes and momenta are summed as integers (exact in any order): this many
// units per m^3, and per m^3 m/s.
constexpr double kVolumeUnits = 1 << 20;
// Loops over boxes or cells: pieces a thread, and the least a piece takes.
constexpr std::size_t kPiecesPerThread = 4;
constexpr std::size_t kMinPerPiece = 1024;
constexpr double kMomentumUnits = 1 << 10;

struct Box {
  Vector3d position;
  Vector3d velocity;
  Eigen::Quaterniond orientation;
  Vector3d spin_axis;  // unit
  double edge;
  double spin = 0;  // rad/s about spin_axis
  float still_seconds = 0;
  bool asleep = false;
};

}  // namespace

// The model itself (see the header).
class GranularModel {
 public:
  GranularModel(const physics::SceneConfig& config, TaskSystem& tasks)
      : tasks_(tasks),
        config_(config),
        layout_(physics::generateScene(config)),
        gravity_rotation_(config.g * config.gravity_scale, config.rotation_per_frame),
        kicks_(config.seed ^ 0x6b69636b73ull) {  // "kicks": apart from the start's draws
    SeededRandom spins(config.seed ^ 0x7370696e73ull);
    double volume = 0;
    boxes_.reserve(layout_.boxes.size());
    for (const physics::BoxStart& start : layout_.boxes) {
      Vector3d axis{spins.uniform(-1, 1), spins.uniform(-1, 1), spins.uniform(-1, 1)};
      if (axis.squaredNorm() < 1e-6) axis = Vector3d::UnitX();
      boxes_.push_back(
          Box{start.position, start.velocity, start.orientation, axis.normalized(), start.edge});
      volume += start.edge * start.edge * start.edge;
    }
    const double half = layout_.half_extent;
    const double cell = kCellInBoxes * std::cbrt(volume / static_cast<double>(boxes_.size()));
    cells_ = std::clamp(static_cast<int>(2 * half / cell), 1, kMaxCellsPerAxis);
    cell_ = 2 * half / cells_;
    const std::size_t count = static_cast<std::size_t>(cells_) * cells_ * cells_;
    volume_.assign(count, 0);
    momentum_.assign(4 * count, 0);
    pressure_.assign(count, 0);
    gradient_.assign(count, Eigen::Vector3f::Zero());
    // Hydrostatic: p rises by g per metre of depth; the deepest pile, about
    // the whole volume at kPileDensity against one wall, is squeezed by kSqueeze.
    const double g = config.g * config.gravity_scale;
    const double depth = std::max(cell_, volume / kPileDensity / (4 * half * half));
    stiffness_ = g * depth / (kSqueeze * kPileDensity);
    const double sound_speed = std::sqrt(stiffness_ * kPileDensity);
    const double needed = std::ceil(config.frame_time * sound_speed / (kCourant * cell_));
    // The simulation's cap on substeps (physics::SubstepRule) holds here too:
    // past it the pile is softer (squeezed beyond kSqueeze), as Bullet's
    // pile gives way past it, instead of a frame of millions of substeps.
    const int most = physics::SubstepRule{}.max_substeps;
    substeps_ = static_cast<int>(std::clamp(needed, 2.0, static_cast<double>(most)));
    if (needed > most) {
      const double capped_speed = kCourant * cell_ * most / config.frame_time;
      stiffness_ = capped_speed * capped_speed / kPileDensity;
    }
  }

  double outerHalfExtent() const { return layout_.outerHalfExtent(); }
  int substeps() const { return substeps_; }

  // One frame; a signal stops it between substeps (a strong gravity makes
  // a frame millions of substeps long).  `frame` is for the message.
  void step(int frame) {
    const Vector3d gravity = config_.rotatingGravity()
                                 ? gravity_rotation_.gravity()
                                 : Vector3d(0, -config_.g * config_.gravity_scale, 0);
    if (config_.kicks()) kick();
    const double dt = config_.frame_time / substeps_;
    for (int substep = 0; substep < substeps_; ++substep) {
      if (pendingInterrupt() != 0) {
        stopIfInterrupted("frame " + std::to_string(frame) + ", substep " +
                          std::to_string(substep) + " of " + std::to_string(substeps_));
      }
      countVolume();
      pushApart();
      forBoxes([&](Box& box) { move(box, gravity, dt); });
      sumMomentum();
      smoothMomentum();
      forBoxes([&](Box& box) { flowWithPile(box, dt); });
    }
    forBoxes([&](Box& box) { turnAndRest(box); });
    if (config_.rotatingGravity()) gravity_rotation_.advanceFrame();
  }

  void appendBoxes(std::vector<physics::Aabb>& out) const {
    const std::size_t first = out.size();
    out.resize(first + boxes_.size());
    parallelFor(boxes_.size(), [&](std::size_t i) {
      const Box& box = boxes_[i];
      const Eigen::Matrix3d turn = box.orientation.toRotationMatrix();
      physics::Aabb& aabb = out[first + i];
      for (int axis = 0; axis < 3; ++axis) {
        const double reach = 0.5 * box.edge * turn.row(axis).cwiseAbs().sum();
        aabb.min[axis] = static_cast<float>(box.position[axis] - reach);
        aabb.max[axis] = static_cast<float>(box.position[axis] + reach);
      }
    });
  }

 private:
  template <typename Body>
  void forBoxes(const Body& body) {
    parallelFor(boxes_.size(), [&](std::size_t i) { body(boxes_[i]); });
  }

  // body(i) for every i < count on the task system's threads; each i writes
  // only its own element, so the pieces do not change the result.
  template <typename Body>
  void parallelFor(std::size_t count, const Body& body) const {
    tasks_.forEachPiece(count, grainFor(count, tasks_.threads(), kPiecesPerThread, kMinPerPiece),
                        [&](std::size_t first, std::size_t end) {
                          for (std::size_t i = first; i != end; ++i) body(i);
                        });
  }

  int cellCoordinate(double x) const {
    return std::clamp(static_cast<int>((x + layout_.half_extent) / cell_), 0, cells_ - 1);
  }
  std::size_t cellIndex(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * cells_ + y) * cells_ + x;
  }

  void kick() {
    const double v = config_.initial_speed;
    for (int k = 0; k < config_.kicks_per_frame; ++k) {
      Box& box = boxes_[kicks_.below(boxes_.size())];
      box.velocity = {kicks_.uniform(-v, v), kicks_.uniform(-v, v), kicks_.uniform(-v, v)};
      box.asleep = false;
      box.still_seconds = 0;
    }
  }

  void countVolume() {
    std::fill(volume_.begin(), volume_.end(), 0);
    forBoxes([&](Box& box) {
      const std::size_t cell = cellOfBox(box);
      const auto units = static_cast<std::uint64_t>(box.edge * box.edge * box.edge * kVolumeUnits);
      std::atomic_ref<std::uint64_t>(volume_[cell]).fetch_add(units, std::memory_order_relaxed);
    });
  }

  std::size_t cellOfBox(const Box& box) const {
    return cellIndex(cellCoordinate(box.position.x()), cellCoordinate(box.position.y()),
                     cellCoordinate(box.position.z()));
  }

  bool inPile(std::size_t cell) const {
    return static_cast<double>(volume_[cell]) / kVolumeUnits >=
           kInPile * kPileDensity * cell_ * cell_ * cell_;
  }

  // Inside a pile the boxes move with their cell, as a granular pile moves
  // together (particle-in-cell): their relative motion, and so the churn of
  // their pairs, stays as small as in the simulation.
  void sumMomentum() {
    std::fill(momentum_.begin(), momentum_.end(), 0);
    forBoxes([&](Box& box) {
      const std::size_t cell = cellOfBox(box);
      if (box.asleep || !inPile(cell)) return;
      const double volume = box.edge * box.edge * box.edge;
      for (int axis = 0; axis < 4; ++axis) {
        const double amount = axis < 3 ? box.velocity[axis] * volume : volume;
        std::atomic_ref<std::int64_t>(momentum_[4 * cell + axis])
            .fetch_add(std::llround(amount * kMomentumUnits), std::memory_order_relaxed);
      }
    });
  }

  // The cells' sums averaged with their neighbours', one axis at a time
  // (integer sums of integers: exact in any order): a pile moves as a
  // block, sliding and turning, not as cells jostling each other.
  void smoothMomentum() {
    const auto cells = static_cast<std::size_t>(cells_);
    for (int pass = 0; pass < 3 * kSmoothingRounds; ++pass) {
      const int axis = pass % 3;
      smoothed_.resize(momentum_.size());
      parallelFor(cells * cells, [&](std::size_t line) {
        const int a = static_cast<int>(line / cells), b = static_cast<int>(line % cells);
        for (int k = 0; k < cells_; ++k) {
          const auto at = [&](int step) {
            const int c = std::clamp(k + step, 0, cells_ - 1);
            return 4 * (axis == 0   ? cellIndex(c, a, b)
                        : axis == 1 ? cellIndex(a, c, b)
                                    : cellIndex(a, b, c));
          };
          for (int value = 0; value < 4; ++value) {
            smoothed_[at(0) + value] =
                momentum_[at(-1) + value] + momentum_[at(0) + value] + momentum_[at(1) + value];
          }
        }
      });
      momentum_.swap(smoothed_);
    }
  }

  void flowWithPile(Box& box, double dt) const {
    const std::size_t cell = cellOfBox(box);
    if (box.asleep || !inPile(cell)) return;
    const auto volume = static_cast<double>(momentum_[4 * cell + 3]);
    if (volume <= 0) return;
    for (int axis = 0; axis < 3; ++axis) {
      box.velocity[axis] = static_cast<double>(momentum_[4 * cell + axis]) / volume;
    }
    box.spin /= 1 + kPileDamping * dt;
  }

  void pushApart() {
    const double cell_volume = cell_ * cell_ * cell_;
    const auto cells = static_cast<std::size_t>(cells_);
    parallelFor(volume_.size(), [&](std::size_t c) {
      const double density = static_cast<double>(volume_[c]) / kVolumeUnits / cell_volume;
      pressure_[c] = static_cast<float>(stiffness_ * std::max(0.0, density - kPileDensity));
    });
    // Central differences; beyond a wall the pressure is the wall cell's.
    parallelFor(cells * cells, [&](std::size_t zy) {
      const int z = static_cast<int>(zy / cells), y = static_cast<int>(zy % cells);
      for (int x = 0; x < cells_; ++x) {
        const auto at = [&](int dx, int dy, int dz) {
          return pressure_[cellIndex(std::clamp(x + dx, 0, cells_ - 1),
                                     std::clamp(y + dy, 0, cells_ - 1),
                                     std::clamp(z + dz, 0, cells_ - 1))];
        };
        const auto scale = static_cast<float>(0.5 / cell_);
        gradient_[cellIndex(x, y, z)] = Eigen::Vector3f((at(1, 0, 0) - at(-1, 0, 0)) * scale,
                                                        (at(0, 1, 0) - at(0, -1, 0)) * scale,
                                                        (at(0, 0, 1) - at(0, 0, -1)) * scale);
      }
    });
  }

  void move(Box& box, const Vector3d& gravity, double dt) const {
    if (box.asleep) return;
    const std::size_t cell = cellOfBox(box);
    box.velocity += (gravity - gradient_[cell].cast<double>()) * dt;
    if (inPile(cell)) box.velocity /= 1 + kPileDamping * dt;
    box.position += box.velocity * dt;
    // The walls: the box's centre stays half its edge inside; what drove it
    // into a wall is lost and brakes its sliding along it.
    const double reach = layout_.half_extent - 0.5 * box.edge;
    for (int axis = 0; axis < 3; ++axis) {
      const double side = box.position[axis] > reach ? 1 : box.position[axis] < -reach ? -1 : 0;
      if (side == 0) continue;
      box.position[axis] = side * reach;
      const double into = box.velocity[axis] * side;
      if (into <= 0) continue;
      box.velocity[axis] = 0;
      const double sliding = box.velocity.norm();
      if (sliding > 0) box.velocity *= std::max(0.0, 1 - kWallFriction * into / sliding);
    }
  }

  void turnAndRest(Box& box) const {
    if (box.asleep) return;
    const double speed = box.velocity.norm();
    // A box in flight spins with its speed; in a pile its spin dies away.
    if (!inPile(cellOfBox(box))) box.spin = kSpin * speed / (0.5 * box.edge);
    const double angle = box.spin * config_.frame_time;
    box.orientation =
        (Eigen::Quaterniond(Eigen::AngleAxisd(angle, box.spin_axis)) * box.orientation)
            .normalized();
    if (!physics::sleepAllowed(config_, physics::SleepMode::kScene)) return;
    box.still_seconds =
        speed < kSleepSpeed ? box.still_seconds + static_cast<float>(config_.frame_time) : 0.0f;
    if (box.still_seconds >= kSleepSeconds) {
      box.asleep = true;
      box.velocity.setZero();
    }
  }

  TaskSystem& tasks_;
  physics::SceneConfig config_;
  physics::SceneLayout layout_;
  physics::GravityRotation gravity_rotation_;
  SeededRandom kicks_;
  std::vector<Box> boxes_;
  int cells_ = 1;
  double cell_ = 1;
  double stiffness_ = 0;
  int substeps_ = 1;
  std::vector<std::uint64_t> volume_;
  std::vector<std::int64_t> momentum_;  // per cell: x, y, z, and the volume they are of
  std::vector<std::int64_t> smoothed_;
  std::vector<float> pressure_;
  std::vector<Eigen::Vector3f> gradient_;
};

std::string generatedSceneName(const physics::SceneConfig& config) {
  return "overlap generate scene " + std::to_string(config.scene) + " seed " +
         std::to_string(config.seed) + " (granular model, no Bullet)";
}

StreamGenerator::StreamGenerator(const physics::SceneConfig& config, int frames, int skip,
                                 double moving_share, TaskSystem& tasks)
    : frames_(frames), skip_(skip) {
  if (frames < 1) throw std::invalid_argument("frames: must be at least 1");
  if (skip < 0) throw std::invalid_argument("skip: must not be negative");
  if (!(moving_share >= 0 && moving_share <= 1)) {
    throw std::invalid_argument("moving: must be in [0, 1]");
  }
  model_ = std::make_unique<GranularModel>(config, tasks);
  header_.scene_name = generatedSceneName(config);
  header_.object_type = "box";
  header_.objects = config.objects;
  header_.stored_frames = frames + 1;
  const auto outer = static_cast<float>(model_->outerHalfExtent());
  header_.world = physics::Aabb{{-outer, -outer, -outer}, {outer, outer, outer}};
  moving_.assign(static_cast<std::size_t>(config.objects), 1);
  if (moving_share < 1) {
    SeededRandom draw(config.seed ^ 0x6d6f76696e67ull);  // "moving"
    for (std::uint8_t& box : moving_) box = draw.unit() < moving_share ? 1 : 0;
  }
}

StreamGenerator::~StreamGenerator() = default;

int StreamGenerator::substepsPerFrame() const {
  return model_->substeps();
}

void StreamGenerator::step() {
  if (done()) throw std::logic_error("StreamGenerator: stepped past the last frame");
  if (steps_ == skip_ && start_.empty()) {
    throw std::logic_error("StreamGenerator: stepped before frame 0 was taken");
  }
  model_->step(steps_ + 1);
  ++steps_;
}

void StreamGenerator::frame(std::vector<physics::Aabb>& boxes) {
  if (steps_ < skip_) throw std::logic_error("StreamGenerator: frame() before the skipped steps");
  boxes.clear();
  model_->appendBoxes(boxes);
  if (steps_ == skip_) {
    start_ = boxes;  // the boxes that do not move keep these
    return;
  }
  for (std::size_t i = 0; i < moving_.size(); ++i) {
    if (moving_[i] == 0) boxes[i] = start_[i];
  }
}

physics::AabbStream generateStream(const physics::SceneConfig& config, int frames, int skip,
                                   double moving_share, TaskSystem& tasks) {
  StreamGenerator generator(config, frames, skip, moving_share, tasks);
  physics::AabbStream stream;
  static_cast<physics::AabbStreamHeader&>(stream) = generator.header();
  stream.boxes.reserve(static_cast<std::size_t>(stream.objects) * stream.stored_frames);
  std::vector<physics::Aabb> boxes;
  while (generator.stepsToStart() > 0) generator.step();
  generator.frame(boxes);
  stream.boxes.insert(stream.boxes.end(), boxes.begin(), boxes.end());
  while (!generator.done()) {
    generator.step();
    generator.frame(boxes);
    stream.boxes.insert(stream.boxes.end(), boxes.begin(), boxes.end());
  }
  return stream;
}

}  // namespace overlap::engine
