// The four scenes of the paper, as docs/SCENES.md fixes them.
//
// A SceneConfig holds every number of a scene, each defaulting to the paper's
// value; generateScene() turns it into a start state without touching Bullet:
// box sizes first, then positions by rejection sampling (largest boxes first,
// no two bounding spheres overlapping, none touching a wall), then random
// orientations and velocities, all from one generator seeded with `seed`, so
// the same config gives the same start on every machine.
// GravityRotation is scenes 3 and 4's rotating gravity, one step per frame.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

namespace overlap::physics {

enum class SizeClass : std::uint8_t { kUnit, kSmall, kAverage, kLarge };

struct SizeRange {
  double lo;
  double hi;
};

struct SceneConfig {
  int scene = 4;                            // 1 fall, 2 kicks, 3 rotating gravity, 4 mixed sizes
  int objects = 3500;                       // dynamic boxes
  std::uint64_t seed = 42;                  // one generator for the whole start state
  double fill_fraction = 0.10;              // share of the interior the boxes' volume fills
  double wall_min_thickness = 2.0;          // walls are max(wall_min_thickness, L * wall_fraction)
  double wall_fraction = 1.0 / 8.0;         //   thick, L = interior edge
  double initial_speed = 5.0;               // each velocity component uniform in [-v, v] m/s
  double frame_time = 1.0 / 30.0;           // seconds of animation per frame
  double g = 9.798;                         // m/s^2
  double gravity_scale = 1.0;               // 1 for scenes 1 and 2, 50 for 3 and 4
  int kicks_per_frame = 25;                 // scene 2: objects given a new velocity each frame
  double rotation_per_frame = 1.0 / 120.0;  // scenes 3 and 4: radians per frame
  SizeRange small{0.1, 0.4};                // scene 4's size classes (edge factors)
  SizeRange average{0.8, 1.2};
  SizeRange large{1.6, 4.0};

  // The paper's defaults for `scene` (1..4).
  static SceneConfig forScene(int scene);
  bool rotatingGravity() const { return scene >= 3; }
  bool mixedSizes() const { return scene == 4; }
  bool kicks() const { return scene == 2; }
  // Throws std::invalid_argument naming the first bad field.
  void validate() const;
};

struct BoxStart {
  double edge;  // metres; mass is edge^3 kg
  SizeClass size_class;
  Eigen::Vector3d position;
  Eigen::Quaterniond orientation;
  Eigen::Vector3d velocity;
};

struct SceneLayout {
  double half_extent;     // interior is [-half_extent, half_extent]^3
  double wall_thickness;  // walls lie just outside the interior
  std::vector<BoxStart> boxes;

  double outerHalfExtent() const { return half_extent + wall_thickness; }
};

// Scene 4's edges (m), what SceneConfig::validate() accepts: Bullet's contact
// distance and breaking threshold are absolute (1 and 2 cm), a box's mass
// (edge^3) and inertia are floats, and the contact solver loses mass ratios
// past 10^6 (an edge ratio of 100) to NaN.
inline constexpr double kSmallestEdge = 0.01;
inline constexpr double kLargestEdge = 1000;
inline constexpr double kMostEdgeRatio = 100;

// Throws std::invalid_argument naming the option at fault if the boxes cannot
// be placed (--fill too high, or too few --objects for the biggest box); a
// signal (gpu/base/interrupt.h) stops the placement with Interrupted.
SceneLayout generateScene(const SceneConfig& config);

std::string sizeClassName(SizeClass size_class);

// Scenes 3 and 4: axes e1, e2, e3 start as i, j, k; each frame e1 turns by the
// rotation angle about e2, then about e3, and gravity turns about e1.
class GravityRotation {
 public:
  GravityRotation(double magnitude, double angle_per_frame);
  const Eigen::Vector3d& gravity() const { return gravity_; }
  void advanceFrame();

 private:
  double angle_;
  Eigen::Vector3d e1_ = Eigen::Vector3d::UnitX();
  Eigen::Vector3d gravity_;
};

}  // namespace overlap::physics
