#include "physics/scene.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "gpu/base/interrupt.h"
#include "gpu/base/random.h"

namespace overlap::physics {
namespace {

// `value` in the fewest digits that read back as the same double.
std::string shortestText(double value) {
  char text[32];
  const auto [end, error] = std::to_chars(text, text + sizeof(text), value);
  return error == std::errc() ? std::string(text, end) : std::string("?");
}

constexpr double kSqrt3 = 1.7320508075688772;
// Rejection sampling gives up on a box after this many tries: at the paper's
// 10% fill a box needs a handful.
constexpr int kMaxPlacementTries = 100000;
// Rejection sampling can also jam: with few boxes the walls leave so little
// room that an unlucky early box leaves no place for a later one, however
// many tries it gets (scene 1 at 50 boxes did).  Placement then starts over,
// drawing on from the same generator, so a config placed at the first
// attempt keeps its start; a jam shows within a few tries, so the later
// attempts give up on a box sooner.  After the last attempt the config is
// refused as an impossible packing.
constexpr int kMaxPlacementAttempts = 64;
constexpr int kRetryPlacementTries = 10000;
// The container's reach from its centre (m): past it a float position is
// coarser than 1 cm.
constexpr double kMostHalfExtent = 1e5;
// Boxes placed between two looks at the signal flag (gpu/base/interrupt.h).
constexpr std::size_t kBoxesBetweenSignalChecks = 1024;

void require(bool ok, const char* field, const std::string& problem) {
  if (!ok) throw std::invalid_argument(std::string(field) + ": " + problem);
}

std::vector<std::pair<double, SizeClass>> drawSizes(const SceneConfig& config,
                                                    SeededRandom& random) {
  const auto n = static_cast<std::size_t>(config.objects);
  std::vector<std::pair<double, SizeClass>> sizes(n, {1.0, SizeClass::kUnit});
  if (!config.mixedSizes()) return sizes;

  // Three equal classes, dealt to objects in a shuffled order (Fisher-Yates).
  std::vector<SizeClass> classes(n);
  for (std::size_t i = 0; i < n; ++i) {
    classes[i] = static_cast<SizeClass>(1 + i % 3);
  }
  for (std::size_t i = n; i > 1; --i) {
    std::swap(classes[i - 1], classes[random.below(i)]);
  }
  for (std::size_t i = 0; i < n; ++i) {
    const SizeRange& range = classes[i] == SizeClass::kSmall     ? config.small
                             : classes[i] == SizeClass::kAverage ? config.average
                                                                 : config.large;
    sizes[i] = {random.uniform(range.lo, range.hi), classes[i]};
  }
  return sizes;
}

// Uniform grid over placed bounding spheres; a cell is as wide as the largest
// sphere's diameter, so a new sphere only needs to check the 27 cells around it.
// Each cell heads a list threaded through the spheres (flat arrays: a
// million boxes place in seconds).
class SphereGrid {
 public:
  SphereGrid(double half_extent, double cell, std::size_t spheres)
      : half_extent_(half_extent),
        cell_(cell),
        cells_(std::max(1, static_cast<int>(std::ceil(2 * half_extent / cell)))),
        head_(static_cast<std::size_t>(cells_) * cells_ * cells_, -1) {
    spheres_.reserve(spheres);
    next_.reserve(spheres);
  }

  bool overlapsAny(const Eigen::Vector3d& centre, double radius) const {
    const Eigen::Vector3i c = cellOf(centre);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const Eigen::Vector3i near = c + Eigen::Vector3i(dx, dy, dz);
          if ((near.array() < 0).any() || (near.array() >= cells_).any()) continue;
          for (std::int32_t i = head_[index(near)]; i >= 0; i = next_[i]) {
            const auto& [other, other_radius] = spheres_[i];
            const double reach = radius + other_radius;
            if ((other - centre).squaredNorm() < reach * reach) return true;
          }
        }
      }
    }
    return false;
  }

  void insert(const Eigen::Vector3d& centre, double radius) {
    std::int32_t& head = head_[index(cellOf(centre))];
    next_.push_back(head);
    head = static_cast<std::int32_t>(spheres_.size());
    spheres_.emplace_back(centre, radius);
  }

 private:
  Eigen::Vector3i cellOf(const Eigen::Vector3d& p) const {
    return ((p.array() + half_extent_) / cell_)
        .floor()
        .cast<int>()
        .cwiseMax(0)
        .cwiseMin(cells_ - 1);
  }
  std::size_t index(const Eigen::Vector3i& c) const {
    return (static_cast<std::size_t>(c.z()) * cells_ + c.y()) * cells_ + c.x();
  }

  double half_extent_;
  double cell_;
  int cells_;                       // per axis
  std::vector<std::int32_t> head_;  // per cell: its last sphere, -1 for none
  std::vector<std::int32_t> next_;  // per sphere: the one before it in its cell
  std::vector<std::pair<Eigen::Vector3d, double>> spheres_;
};

// Uniformly distributed rotation (Shoemake's method).
Eigen::Quaterniond randomOrientation(SeededRandom& random) {
  const double u1 = random.unit();
  const double u2 = random.uniform(0.0, 2.0 * std::numbers::pi);
  const double u3 = random.uniform(0.0, 2.0 * std::numbers::pi);
  const double a = std::sqrt(1.0 - u1);
  const double b = std::sqrt(u1);
  return Eigen::Quaterniond(a * std::cos(u2), a * std::sin(u2), b * std::cos(u3), b * std::sin(u3));
}

// One attempt at placing every box, in `order`, uniform in the interior with
// no two bounding spheres overlapping and none reaching a wall.  Returns the
// box that found no place in `max_tries` draws, or nothing when all are placed.
std::optional<std::size_t> placeBoxes(const std::vector<std::pair<double, SizeClass>>& sizes,
                                      const std::vector<std::size_t>& order, SceneLayout& layout,
                                      double cell, int max_tries, SeededRandom& random) {
  SphereGrid grid(layout.half_extent, cell, sizes.size());
  std::size_t placed = 0;
  for (const std::size_t i : order) {
    // Millions of boxes take seconds: a signal stops the placement within it.
    if (placed++ % kBoxesBetweenSignalChecks == 0 && pendingInterrupt() != 0) {
      stopIfInterrupted("placing box " + std::to_string(placed) + " of " +
                        std::to_string(sizes.size()));
    }
    const double radius = sizes[i].first * kSqrt3 / 2;
    const double reach = layout.half_extent - radius;  // sphere stays off the walls
    int tries = 0;
    Eigen::Vector3d centre;
    do {
      if (++tries > max_tries) return i;
      centre = {random.uniform(-reach, reach), random.uniform(-reach, reach),
                random.uniform(-reach, reach)};
    } while (grid.overlapsAny(centre, radius));
    grid.insert(centre, radius);
    layout.boxes[i].position = centre;
  }
  return std::nullopt;
}

}  // namespace

SceneConfig SceneConfig::forScene(int scene) {
  SceneConfig config;
  config.scene = scene;
  config.gravity_scale = scene >= 3 ? 50.0 : 1.0;
  return config;
}

void SceneConfig::validate() const {
  require(scene >= 1 && scene <= 4, "scene", "must be 1, 2, 3 or 4");
  require(objects >= 1, "objects", "must be at least 1");
  require(fill_fraction > 0 && fill_fraction <= 0.3, "fill",
          "must be in (0, 0.3]: denser packings cannot be placed by rejection sampling");
  require(wall_min_thickness > 0 && std::isfinite(wall_min_thickness), "wall-min",
          "must be positive");
  require(wall_fraction >= 0 && std::isfinite(wall_fraction), "wall-fraction",
          "must be non-negative");
  require(initial_speed >= 0 && std::isfinite(initial_speed), "initial-speed",
          "must be non-negative");
  require(frame_time > 0 && frame_time <= 1, "frame-time", "must be in (0, 1] s");
  require(std::isfinite(g) && std::isfinite(gravity_scale), "gravity", "must be finite");
  require(kicks_per_frame >= 0, "kicks", "must be non-negative");
  require(std::isfinite(rotation_per_frame), "rotation", "must be finite");
  for (const auto& [range, name] :
       {std::pair{small, "small-sizes"}, std::pair{average, "average-sizes"},
        std::pair{large, "large-sizes"}}) {
    require(range.lo >= kSmallestEdge && range.lo <= range.hi && range.hi <= kLargestEdge, name,
            "needs 0.01 <= lo <= hi <= 1000 (m): Bullet's contact distances are absolute (1 cm), "
            "and a box's mass (edge^3) and inertia must stay floats");
  }
  if (mixedSizes()) {
    const double smallest = std::min({small.lo, average.lo, large.lo});
    const double largest = std::max({small.hi, average.hi, large.hi});
    const char* largest_name = largest == large.hi     ? "large-sizes"
                               : largest == average.hi ? "average-sizes"
                                                       : "small-sizes";
    // The ratio compared is the one printed, in the shortest digits that
    // read back as it: a refused ratio never reads as 100.  Edges are read
    // as decimals, so a ratio within 10^-12 of the bound is the bound's
    // (1.3 / 0.013 is 100.00000000000001 in doubles).
    const double edge_ratio = largest / smallest;
    constexpr double kDecimalSlack = 1e-12;
    const std::string ratio = "its " + shortestText(largest) + " is " + shortestText(edge_ratio) +
                              " times the smallest edge, " + shortestText(smallest);
    require(edge_ratio <= kMostEdgeRatio * (1 + kDecimalSlack), largest_name,
            ratio +
                "; scene 4's largest edge may be at most 100 times its smallest (a mass ratio "
                "of 10^6, the most Bullet's contact solver holds without NaN)");
  }
}

SceneLayout generateScene(const SceneConfig& config) {
  config.validate();
  SeededRandom random(config.seed);
  const auto sizes = drawSizes(config, random);

  const double volume =
      std::accumulate(sizes.begin(), sizes.end(), 0.0,
                      [](double sum, const auto& s) { return sum + s.first * s.first * s.first; });
  SceneLayout layout;
  const double interior_edge = std::cbrt(volume / config.fill_fraction);
  layout.half_extent = interior_edge / 2;
  layout.wall_thickness = std::max(config.wall_min_thickness, interior_edge * config.wall_fraction);
  if (!(layout.outerHalfExtent() <= kMostHalfExtent)) {
    std::ostringstream text;
    text << config.fill_fraction << " with " << config.objects << " boxes of these sizes needs a "
         << "container reaching " << layout.outerHalfExtent() << " m from its centre, over 1e5 m "
         << "(a float position there is coarser than 1 cm); raise --fill or lower --objects, "
         << "the sizes or --wall-min";
    throw std::invalid_argument("fill: " + text.str());
  }
  layout.boxes.resize(sizes.size());

  // Largest first: they are the hardest to fit once the space fills up.
  std::vector<std::size_t> order(sizes.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return sizes[a].first > sizes[b].first; });
  const double largest_radius = sizes[order.front()].first * kSqrt3 / 2;
  if (layout.half_extent - largest_radius <= 0) {  // the sphere cannot stay off the walls
    throw std::invalid_argument("objects: " + std::to_string(config.objects) +
                                " leave no room in the container for a box of edge " +
                                std::to_string(sizes[order.front()].first) + " m; raise --objects");
  }
  for (int attempt = 1;; ++attempt) {
    const int max_tries = attempt == 1 ? kMaxPlacementTries : kRetryPlacementTries;
    const std::optional<std::size_t> stuck =
        placeBoxes(sizes, order, layout, 2 * largest_radius, max_tries, random);
    if (!stuck) break;
    if (attempt == kMaxPlacementAttempts) {
      std::ostringstream fill;
      fill << config.fill_fraction;
      throw std::invalid_argument(
          "fill: " + fill.str() + " leaves no room for " + std::to_string(config.objects) +
          " boxes: box " + std::to_string(*stuck) + " found no place without overlap in " +
          std::to_string(kMaxPlacementAttempts) + " attempts; lower --fill or raise --objects");
    }
  }

  for (std::size_t i = 0; i < sizes.size(); ++i) {
    BoxStart& box = layout.boxes[i];
    box.edge = sizes[i].first;
    box.size_class = sizes[i].second;
    box.orientation = randomOrientation(random);
    const double v = config.initial_speed;
    box.velocity = {random.uniform(-v, v), random.uniform(-v, v), random.uniform(-v, v)};
  }
  return layout;
}

std::string sizeClassName(SizeClass size_class) {
  switch (size_class) {
    case SizeClass::kUnit:
      return "unit";
    case SizeClass::kSmall:
      return "small";
    case SizeClass::kAverage:
      return "average";
    case SizeClass::kLarge:
      return "large";
  }
  return "unknown";
}

GravityRotation::GravityRotation(double magnitude, double angle_per_frame)
    : angle_(angle_per_frame), gravity_(0.0, -magnitude, 0.0) {}

void GravityRotation::advanceFrame() {
  e1_ = Eigen::AngleAxisd(angle_, Eigen::Vector3d::UnitY()) * e1_;
  e1_ = Eigen::AngleAxisd(angle_, Eigen::Vector3d::UnitZ()) * e1_;
  e1_.normalize();
  gravity_ = Eigen::AngleAxisd(angle_, e1_) * gravity_;
}

}  // namespace overlap::physics
