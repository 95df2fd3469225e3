// What a frame needs modelled: substeps, continuous collision detection and
// sleep, each chosen by one small function whose rule is stated beside it.
//
// The functions read plain numbers (speeds, edges, gravity, times) and never
// touch Bullet, so they are deterministic by construction: the same state
// gives the same choice.  PhysicsWorld gathers the numbers at the start of a
// frame (after the scene's kicks and gravity turn) and applies the answers.
//
// Invariants: chooseSubsteps() returns a K in [1, rule.max_substeps];
// chooseCcdBodies() returns one flag per box, in box order.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "physics/scene.h"

namespace overlap::physics {

// `--substeps`: 0 chooses K every frame (chooseSubsteps); K >= 1 is fixed.
constexpr int kAutoSubsteps = 0;

enum class CcdMode { kOff, kAuto, kAll };
enum class SleepMode { kScene, kOn, kOff };  // kScene: sleepAllowed()'s default

// Parses "off|auto|all" and "scene|on|off"; throws std::invalid_argument.
CcdMode parseCcdMode(const std::string& text);
SleepMode parseSleepMode(const std::string& text);
// Parses "auto" (kAutoSubsteps) or an integer K >= 1; throws std::invalid_argument.
int parseSubsteps(const std::string& text);
std::string ccdModeName(CcdMode mode);
std::string sleepModeName(SleepMode mode);

// The numbers of the automatic rule.  Each bound is a share of a length a box
// must not cross in one substep; K is the least that keeps all of them.
struct SubstepRule {
  // Box against wall: a box tunnels once one substep carries its centre past
  // a wall's middle (measured: 1.05 m a step through 2.0 m walls, not 2.2 m).
  double wall_share = 0.35;
  // Box against box without CCD: the fastest box against the smallest edge.
  // With CCD on, the small boxes that could pass through others are swept
  // instead (chooseCcdBodies), so this bound is left to CCD.
  double edge_share = 0.5;
  // How far any box may move in one substep, as a share of the typical
  // (median) edge: a box meets a wall or a pile up to one substep's motion
  // deep before a contact holds it, so this bounds the penetration on impact
  // (measured in scene 3's first fall: 0.58 edges at 0.56 m a substep).
  double motion_share = 0.5;
  // Resting contact under strong gravity, the solver's limit: one substep's
  // free fall, g dt^2, stays under this share of the typical edge, or a
  // deep pile compresses into itself faster than the solver's 10 iterations
  // push it back out (scene 3's pile crept to 1.1 edges deep at 2 substeps,
  // 0.6 at 4, 0.16 at 6 within 90 frames).
  double resting_share = 0.03;
  int max_substeps = 16;
};

// What chooseSubsteps() reads from the frame's start.
struct FrameMotion {
  double fastest_speed;   // m/s, the fastest box in the simulation
  double gravity;         // |g| this frame, m/s^2
  double frame_time;      // s
  double smallest_edge;   // m, of the boxes in the scene
  double typical_edge;    // m, typicalEdge()
  double wall_thickness;  // m
};

// The edge the motion and resting rules measure against: the median box's.
// Not the volume-weighted median (3.4 m in scene 4, where the large boxes
// hold most of the volume): its K = 3 floor let small boxes sink into the
// walls under the resting pile, up to 4 at once and more as it settled.
// 0 for no boxes.
double typicalEdge(std::span<const double> edges);

// A box's speed can grow by at most g T during a frame before a contact
// acts on it; the bound the substep and CCD rules plan against.
double speedBound(double speed, double gravity, double frame_time);

// K: the least number of equal substeps such that
//   (a) the fastest box (speedBound) moves at most wall_share of a wall's
//       thickness and motion_share of the typical edge per substep;
//   (b) without CCD, it also moves at most edge_share of the smallest edge;
//   (c) a resting pile is stable: g (T/K)^2 <= resting_share x typical edge;
// capped at max_substeps (the cap wins over (a)-(c): the frame's cost is
// bounded, and CCD covers what a capped K leaves).
int chooseSubsteps(const FrameMotion& motion, bool ccd_on, const SubstepRule& rule = {});

// The share of its own edge a box may move in one substep before Bullet's
// swept-sphere CCD must take over for it (also the motion threshold Bullet
// applies within the frame).
constexpr double kCcdShareOfEdge = 0.5;
// The swept sphere's radius, a share of the box's edge: inside the box (its
// inscribed sphere is 0.5), so that every swept hit is a real hit.
constexpr double kCcdSweptSphereShare = 0.4;

// CCD bodies for this frame: box i needs CCD when its speedBound times the
// substep (frame_time / substeps) exceeds kCcdShareOfEdge of its own edge:
// the small, fast boxes.  kAll flags every box, kOff none.
std::vector<char> chooseCcdBodies(CcdMode mode, std::span<const float> speeds,
                                  std::span<const double> edges, double gravity, double frame_time,
                                  int substeps);

// Sleep (Bullet's deactivation: a box at rest for 2 s stops being simulated
// until something touches it) is allowed by default where gravity is fixed,
// scenes 1 and 2.  Scenes 3 and 4 turn gravity every frame and a sleeping
// box would not notice, so asking for sleep there throws
// std::invalid_argument.
bool sleepAllowed(const SceneConfig& config, SleepMode mode);

}  // namespace overlap::physics
