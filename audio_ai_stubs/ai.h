// AgentCrowd: the game's AI system, a stand-in with a real workload.  K agents
// fly through the container among the boxes, steered each frame by Reynolds'
// behaviours: seek a wandering target, keep apart from each other, and turn
// away from the boxes ahead.  It reads last frame's box positions (the engine
// copies them out of Bullet before the frame starts), so it can run on a
// worker thread while the physics steps this frame.
//
// Each frame rebuilds a uniform grid over the boxes and one over the agents,
// so neighbour queries cost about O(K * local density), not O(K * n).  All
// agents steer from the same snapshot of positions and then move together, so
// the result does not depend on the order agents are visited.
//
// Invariants: every agent's centre stays at least agent_radius inside the
// container's interior (in a container too small for agent_radius plus
// wall_margin both shrink to fit, so any container with an interior works).  Steering keeps agents
// clear of boxes; an agent that a moving box catches anyway is pushed out to the box's bounding
// sphere and counted (where spheres crowd together, that push can land it in a neighbour's).  The
// same config, start and box sequence give bit-identical agents on any thread.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "audio_ai_stubs/uniform_grid.h"
#include "gpu/base/random.h"

namespace overlap::stubs {

// A box as the AI sees it: its bounding sphere.
struct Obstacle {
  Eigen::Vector3f centre;
  float radius;
};

struct AiConfig {
  int agents = 256;                  // the main cost knob
  float agent_radius = 0.3f;         // m
  float max_speed = 4.0f;            // m/s
  float max_acceleration = 12.0f;    // m/s^2, the steering budget per agent
  float look_ahead_seconds = 1.0f;   // boxes closer than max_speed x this are avoided
  float separation_distance = 1.5f;  // agents closer than this push apart
  float arrival_distance = 1.0f;     // a wander target this close counts as reached
  float retarget_seconds = 8.0f;     // a target not reached by then is replaced
  float wall_margin = 1.0f;          // agents turn from walls this close; targets stay out
  float grid_cell_size = 2.0f;       // m, for both neighbour grids
  double frame_seconds = 1.0 / 30.0;
  std::uint64_t seed = 42;  // start positions and wander targets

  // Throws std::invalid_argument naming the first bad field.
  void validate() const;
};

// Cumulative counts of what the crowd did, for tests and reports.
struct AiWork {
  std::uint64_t frames = 0;
  std::uint64_t agent_box_tests = 0;    // exact distance tests against boxes
  std::uint64_t agent_agent_tests = 0;  // exact distance tests between agents
  std::uint64_t targets_reached = 0;
  std::uint64_t penetrations_resolved = 0;  // agents pushed out of a box
};

class AgentCrowd {
 public:
  // The interior is [-container_half_extent, container_half_extent]^3; throws
  // std::invalid_argument if it has none or `config` is invalid.
  AgentCrowd(const AiConfig& config, float container_half_extent);

  // Steers and moves every agent by one frame among `boxes`.
  void runFrame(std::span<const Obstacle> boxes);

  // Places agent `index` at rest at `position` (clamped into the interior),
  // heading for `target` until it reaches it or gives up.
  void placeAgent(std::size_t index, const Eigen::Vector3f& position,
                  const Eigen::Vector3f& target);

  std::span<const Eigen::Vector3f> positions() const { return positions_; }
  std::span<const Eigen::Vector3f> velocities() const { return velocities_; }
  // FNV-1a over every position and velocity, for determinism checks.
  std::uint64_t checksum() const;
  const AiWork& work() const { return work_; }

 private:
  Eigen::Vector3f seek(std::size_t agent);
  Eigen::Vector3f separation(std::size_t agent);
  Eigen::Vector3f avoidBoxes(std::size_t agent, std::span<const Obstacle> boxes);
  Eigen::Vector3f avoidWalls(std::size_t agent) const;
  void resolvePenetrations(std::size_t agent, std::span<const Obstacle> boxes);
  void clampToInterior(std::size_t agent);
  Eigen::Vector3f randomInteriorPoint();

  AiConfig config_;
  float half_extent_;
  float largest_box_radius_ = 0.0f;  // this frame's, widens box queries
  SeededRandom random_;
  std::vector<Eigen::Vector3f> positions_;
  std::vector<Eigen::Vector3f> velocities_;
  std::vector<Eigen::Vector3f> targets_;
  std::vector<float> seconds_on_target_;
  std::vector<Eigen::Vector3f> accelerations_;  // runFrame()'s scratch
  std::vector<Eigen::Vector3f> box_centres_;    // runFrame()'s scratch
  UniformGrid box_grid_;
  UniformGrid agent_grid_;
  AiWork work_;
};

}  // namespace overlap::stubs
