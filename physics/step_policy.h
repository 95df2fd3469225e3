// What a frame needs modelled: substeps, continuous collision detection,
// sleep and the contact solver's settings, each chosen by one small function
// whose rule is stated beside it.
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
enum class SolverMode { kPile, kBullet };    // solverSettings()

// Parses "off|auto|all", "scene|on|off" and "pile|bullet"; throws std::invalid_argument.
CcdMode parseCcdMode(const std::string& text);
SleepMode parseSleepMode(const std::string& text);
SolverMode parseSolverMode(const std::string& text);
// Parses "auto" (kAutoSubsteps) or an integer K >= 1; throws std::invalid_argument.
int parseSubsteps(const std::string& text);
std::string ccdModeName(CcdMode mode);
std::string sleepModeName(SleepMode mode);
std::string solverModeName(SolverMode mode);

// The numbers of the automatic rule.  Each bound is a share of a length a box
// must not cross in one substep; K is the least that keeps all of them.
struct SubstepRule {
  // Box against wall: a box tunnels once one substep carries its centre past
  // a wall's middle (measured: 1.05 m a step through 2.0 m walls, not 2.2 m).
  double wall_share = 0.35;
  // Box against box without CCD: the closing motion against the smallest
  // edge.  With CCD on, the small boxes that could pass through others are
  // swept instead (chooseCcdBodies), so this bound is left to CCD.
  double edge_share = 0.5;
  // How far two bodies may close in one substep, as a share of the typical
  // (median) edge: a box meets a wall, a pile or another box up to one
  // substep's closing motion deep before a contact holds it, so this bounds
  // the penetration on impact (measured: scene 3's first fall, 0.58 edges
  // at 0.56 m a substep; scene 2's kicked boxes, 0.60 edges at K = 1 and
  // 0.28 at K = 2, where two of them close at up to 0.58 m a frame).
  double motion_share = 0.5;
  // A pile under strong gravity, the solver's limit: one substep's free
  // fall, g (T/K)^2, stays under this share of the typical edge, or the
  // pile's bottom layer gives way: boxes squeezed into the corner gravity
  // points at merge into each other, and the deepest overlap grows towards a
  // whole edge.  Measured in scene 3 with SolverMode::kPile over 240 frames
  // (deepest overlap in the last 100), 1000 boxes: K = 4 held (g (T/K)^2 =
  // 0.034 m; 0.44, 0.54, 0.51 edges at seeds 42, 7, 123) and K = 3 gave way
  // (0.92, 0.060 m; measured with 10 iterations).  3500 boxes, a pile half
  // again as deep, is at the rule's limit: K = 4 reached 0.82 edges with
  // kPile's 8 iterations (0.56 with 10), K = 3 0.89.  Bullet's own settings
  // (SolverMode::kBullet) need more: 1000 boxes gave way at K = 6 and held at
  // 7; 3500 gave way even at K = 8 (0.95 edges).
  double fall_share = 0.04;
  int max_substeps = 16;
};

// The two fastest boxes' speeds (m/s) of a set: no two boxes of it close
// faster than their sum.
struct TopSpeeds {
  double fastest = 0;
  double second = 0;
  void add(double speed);
};

// What chooseSubsteps() reads from the frame's start.
struct FrameMotion {
  TopSpeeds all;          // every box in the simulation
  TopSpeeds typical;      // the boxes at least typical_edge, inTypicalEdges()
  double gravity;         // |g| this frame, m/s^2
  double frame_time;      // s
  double smallest_edge;   // m, of the boxes in the scene
  double typical_edge;    // m, typicalEdge()
  double wall_thickness;  // m
};

// The edge the motion and pile rules measure against: the median box's.
// Not the volume-weighted median (3.4 m in scene 4, where the large boxes
// hold most of the volume): its K = 3 floor let small boxes sink into the
// walls under the resting pile, up to 4 at once and more as it settled.
// 0 for no boxes.
double typicalEdge(std::span<const double> edges);

// A box's speed in typical edges: speed x typical_edge / edge.  How deep a
// box closes on what it meets is an error in its own edges (a 4 m box 1 m
// into a wall is a quarter of an edge deep), so a box larger than the
// typical one may move further per substep: a 4 m box at 100 m/s needs the
// substeps of a 1 m box at 25.  Measured in scene 4 (240 frames, --ccd
// auto), where the fastest boxes of at least the typical edge were 2.5-4 m
// boxes thrown at 80-100 m/s: at 1000 boxes the mean K fell from 6.2, 6.3,
// 6.1 to 4.8, 5.2, 4.8 (seeds 42, 7, 123), the deepest penetration went
// from 2.08, 2.44, 1.87 edges to 2.36, 1.97, 2.37 and the most boxes sunk
// from 1, 1, 0 to 2, 1, 0; at 3500 boxes K fell from 8.7 to 6.1 and the
// penetration from 2.61 to 2.37 edges (1 box sunk in both).
double inTypicalEdges(double speed, double edge, double typical_edge);

// A box's speed can grow by at most g T during a frame before a contact
// acts on it; the bound the substep and CCD rules plan against.
double speedBound(double speed, double gravity, double frame_time);

// K: the least number of equal substeps such that, per substep,
//   (a) no box crosses more than wall_share of a wall's thickness, at its
//       speedBound (its speed plus what gravity adds in the frame);
//   (b) no two bodies close by more than motion_share of the typical edge:
//       a box on a wall at its speedBound, two boxes at the sum of the two
//       fastest speeds (gravity pulls both alike, so it adds nothing
//       between them);
//   (c) without CCD, neither do they by more than edge_share of the
//       smallest edge;
//   (d) the pile holds: g (T/K)^2 <= fall_share x typical edge.
// With CCD on, (b) reads the boxes at least the typical edge, each at its
// speed inTypicalEdges(): a smaller box that is fast for its size is swept this frame
// (chooseCcdBodies) instead of every box being substepped for it (in scene 4 the fastest box is a
// 0.1-0.4 m one squeezed out of the pile at 35-100 m/s); (a) still reads
// every box.  Capped at max_substeps (the cap wins over (a)-(d): the frame's
// cost is bounded, and CCD covers what a capped K leaves).
// (b) reads the centres' speeds, not the corners': a spinning box's corners
// close faster (scene 2's deepest overlaps, 0.3-0.37 edges, are spinning
// boxes in K = 1 frames), but adding |w| x half-diagonal to every speed
// cost scene 4 at 3500 boxes 39% more time for the same penetration
// (mean K 6.1 -> 8.7), past the 50 g time target; docs/REPORT.md 3.2.
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

// Bullet's sequential-impulse contact solver, as PhysicsWorld sets it up.
struct SolverSettings {
  int iterations;              // Gauss-Seidel sweeps over the contacts per substep
  double warmstarting_factor;  // share of last substep's impulse each contact starts from
  bool split_impulse;          // overlap pushed out by a separate position pass, not by velocity
};

// kBullet: Bullet 3.24's defaults: 10 iterations, warm start 0.85, overlaps
// deeper than 4 cm pushed out by a separate position pass (split impulse),
// shallower ones in the velocity solve, both at 20% (m_erp2) a substep.
// kPile, the default: 8 iterations, warm start 1, every overlap pushed out
// inside the velocity solve.  A pile under 50 g keeps almost the same
// contact impulses from one substep to the next, so starting from all of
// last substep's impulse leaves the iterations less to do; and pushing
// overlaps out in the velocity solve solves the pile's weight and its
// push-out together, where the split pass undid part of what the velocity
// pass did.  Measured in scene 3 at K = 4 (1000 boxes, 240 frames, seeds
// 42, 7, 123; the deepest overlap in the last 100 frames): kBullet's pile
// gave way (1.0 edges); kPile with 10 iterations held (0.52, 0.59, 0.60),
// with 8 held as well for 7% less time (0.44, 0.54, 0.51), with 6 less well
// (0.60, 0.78, 0.66); a stiffer push-out (m_erp2 0.35, 0.5) did worse, and
// m_erp2 0.25 or 0.3 moved the deepest overlap both ways seed by seed under
// --substeps auto (seeds 2, 3, 4, 7, 123); 12 iterations lowered it at
// seeds 3 and 4 (0.65, 0.64 -> 0.40, 0.47) for 9-14% more time.
SolverSettings solverSettings(SolverMode mode);

}  // namespace overlap::physics
