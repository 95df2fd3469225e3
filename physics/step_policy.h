// What a frame needs modelled: substeps, continuous collision detection,
// sleep and the contact solver's settings, each chosen by one small function
// whose rule is stated beside it.  docs/REPORT.md section 3.2 measures the
// rules as shipped; the measurements that chose them, with their commits,
// are in docs/results/step_policy.md (with the record of the report's first
// section 3.2).
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
// The most substeps a frame may be given.  parseSubsteps() reads K in plain
// decimal digits, as every whole-number option reads them (an optional '+';
// "010" and " 5" are refused).
inline constexpr int kMostSubsteps = 1000;

enum class CcdMode { kOff, kAuto, kAll };
enum class SleepMode { kScene, kOn, kOff };  // kScene: sleepAllowed()'s default
enum class SolverMode { kPile, kBullet };    // solverSettings()
// The order the contact solver sweeps its rows in: kColoured, colour after
// colour with each colour's manifolds in parallel, the same result for every
// thread count (physics/coloured_solver.h); kSerial, Bullet's stock
// btSequentialImpulseConstraintSolver, in manifold order on one thread.
enum class SolverOrder { kColoured, kSerial };
// How the narrowphase runs (physics/parallel_dispatcher.h); every mode gives
// the same contacts in the same order, so the same state.
enum class NarrowphaseMode {
  kBullet,        // Bullet's serial dispatch
  kParallel,      // the box-box pairs' contacts on the task system
  kBesideSearch,  // kParallel, and the cached pairs' contacts while our finder searches
};

// Parses "off|auto|all", "scene|on|off", "pile|bullet" and "coloured|serial";
// throws std::invalid_argument.
CcdMode parseCcdMode(const std::string& text);
SleepMode parseSleepMode(const std::string& text);
SolverMode parseSolverMode(const std::string& text);
SolverOrder parseSolverOrder(const std::string& text);
// Parses "bullet|parallel|beside-search"; throws std::invalid_argument.
NarrowphaseMode parseNarrowphaseMode(const std::string& text);
// Parses "auto" (kAutoSubsteps) or an integer K >= 1; throws std::invalid_argument.
int parseSubsteps(const std::string& text);
std::string ccdModeName(CcdMode mode);
std::string sleepModeName(SleepMode mode);
std::string solverModeName(SolverMode mode);
std::string solverOrderName(SolverOrder order);
std::string narrowphaseModeName(NarrowphaseMode mode);

// The numbers of the automatic rule.  Each bound is a share of a length a box
// must not cross in one substep; K is the least that keeps all of them.
struct SubstepRule {
  // Box against wall: a box tunnels once one substep carries its centre past
  // a wall's middle; 0.35 keeps a margin under that half.
  double wall_share = 0.35;
  // Box against box without CCD: the closing motion against the smallest
  // edge.  With CCD on, the small boxes that could pass through others are
  // swept instead (chooseCcdBodies), so this bound is left to CCD.
  double edge_share = 0.5;
  // How far two bodies may close in one substep, as a share of the typical
  // (median) edge: a box meets a wall, a pile or another box up to one
  // substep's closing motion deep before a contact holds it, so this bounds
  // the penetration on impact.
  double motion_share = 0.5;
  // A pile under strong gravity, the solver's limit: one substep's free
  // fall, g (T/K)^2, stays under this share of the typical edge, or the
  // pile's bottom layer gives way: boxes squeezed into the corner gravity
  // points at merge into each other, and the deepest overlap grows towards a
  // whole edge.  With SolverMode::kPile at 50 g this makes K = 4 the floor:
  // the least K whose pile held in scene 3 at 1000 boxes (at 3500, a deeper
  // pile, K = 4 is at the limit; Bullet's own solver settings need more
  // substeps than any rule can afford).
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
// Not the volume-weighted median: in scene 4 the large boxes hold most of
// the volume, and the lower floor that edge gives let small boxes sink into
// the walls under the resting pile.  0 for no boxes.
double typicalEdge(std::span<const double> edges);

// A box's speed in typical edges: speed x typical_edge / edge.  How deep a
// box closes on what it meets is an error in its own edges (a 4 m box 1 m
// into a wall is a quarter of an edge deep), so a box larger than the
// typical one may move further per substep: a 4 m box at 100 m/s needs the
// substeps of a 1 m box at 25.  In scene 4 the large boxes thrown across the
// container would otherwise set K as if they were 1 m boxes.
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
// speed inTypicalEdges(): a smaller box that is fast for its size is swept
// this frame (chooseCcdBodies) instead of every box being substepped for it
// (in scene 4 the fastest box is usually a small one squeezed out of the
// pile); (a) still reads every box.  Capped at max_substeps (the cap wins over (a)-(d): the frame's
// cost is bounded, and CCD covers what a capped K leaves).
// (b) reads the centres' speeds, not the corners': a spinning box's corners
// close faster (scene 2's deepest overlaps are spinning boxes in one-step
// frames), but counting spin in every speed adds substeps at 50 g for the
// same penetration, past the time target (docs/results/step_policy.md).
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
// pass did.  8 iterations: the fewest that held scene 3's pile at K = 4;
// more cost time without a gain that holds from seed to seed
// (docs/results/step_policy.md).
SolverSettings solverSettings(SolverMode mode);

}  // namespace overlap::physics
