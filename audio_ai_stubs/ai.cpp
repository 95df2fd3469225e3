#include "audio_ai_stubs/ai.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "gpu/base/checksum.h"

namespace overlap::stubs {
namespace {

static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "positions are hashed as floats");

// How fast seek closes the gap between the velocity it has and the one it
// wants: a smaller value turns more sharply.
constexpr float kSeekReactionSeconds = 0.5f;
constexpr float kTinyLength = 1e-4f;

// Reynolds' prioritised acceleration allocation: each behaviour, in order of
// importance, gets what it asks for until the budget is spent, so a strong
// seek never drowns out the turn that avoids a box.
void allocate(Eigen::Vector3f& total, const Eigen::Vector3f& request, float budget) {
  const float remaining = budget - total.norm();
  if (remaining <= 0.0f) return;
  const float length = request.norm();
  total += length > remaining ? Eigen::Vector3f(request * (remaining / length)) : request;
}

Eigen::Vector3f perpendicularTo(const Eigen::Vector3f& direction) {
  const Eigen::Vector3f candidate = direction.cross(Eigen::Vector3f::UnitY());
  return candidate.norm() > 0.1f ? candidate.normalized()
                                 : direction.cross(Eigen::Vector3f::UnitZ()).normalized();
}

}  // namespace

void AiConfig::validate() const {
  auto fail = [](const std::string& field, const std::string& why) {
    throw std::invalid_argument("AiConfig." + field + " " + why);
  };
  if (agents < 0) fail("agents", "must be non-negative");
  if (!(agent_radius > 0.0f)) fail("agent_radius", "must be positive");
  if (!(max_speed > 0.0f)) fail("max_speed", "must be positive");
  if (!(max_acceleration > 0.0f)) fail("max_acceleration", "must be positive");
  if (!(look_ahead_seconds > 0.0f)) fail("look_ahead_seconds", "must be positive");
  if (!(separation_distance >= 0.0f)) fail("separation_distance", "must be non-negative");
  if (!(arrival_distance > 0.0f)) fail("arrival_distance", "must be positive");
  if (!(retarget_seconds > 0.0f)) fail("retarget_seconds", "must be positive");
  if (!(wall_margin >= 0.0f)) fail("wall_margin", "must be non-negative");
  if (!(grid_cell_size > 0.0f)) fail("grid_cell_size", "must be positive");
  if (!(frame_seconds > 0.0)) fail("frame_seconds", "must be positive");
}

AgentCrowd::AgentCrowd(const AiConfig& config, float container_half_extent)
    : config_(config), half_extent_(container_half_extent), random_(config.seed) {
  config_.validate();
  if (!(half_extent_ > 0.0f) || !std::isfinite(half_extent_)) {
    throw std::invalid_argument("AgentCrowd: container half extent " +
                                std::to_string(half_extent_) + " m has no interior");
  }
  // A container too small for an agent and its wall margin (a scene of one
  // box is about 1 m across) gets agents scaled down to fit: radius and margin
  // shrink together to half the half extent, so every scene the physics
  // accepts has a crowd.
  const float room = config_.agent_radius + config_.wall_margin;
  if (!(half_extent_ > room)) {
    const float scale = 0.5f * half_extent_ / room;
    config_.agent_radius *= scale;
    config_.wall_margin *= scale;
  }
  const auto count = static_cast<std::size_t>(config_.agents);
  positions_.resize(count);
  targets_.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    positions_[i] = randomInteriorPoint();
    targets_[i] = randomInteriorPoint();
  }
  velocities_.assign(count, Eigen::Vector3f::Zero());
  seconds_on_target_.assign(count, 0.0f);
  accelerations_.resize(count);
}

void AgentCrowd::placeAgent(std::size_t index, const Eigen::Vector3f& position,
                            const Eigen::Vector3f& target) {
  if (index >= positions_.size()) {
    throw std::out_of_range("AgentCrowd::placeAgent: agent " + std::to_string(index) + " of " +
                            std::to_string(positions_.size()));
  }
  positions_[index] = position;
  velocities_[index].setZero();
  targets_[index] = target;
  seconds_on_target_[index] = 0.0f;
  clampToInterior(index);
}

void AgentCrowd::runFrame(std::span<const Obstacle> boxes) {
  box_centres_.resize(boxes.size());
  largest_box_radius_ = 0.0f;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    if (!boxes[i].centre.allFinite() || !(boxes[i].radius >= 0.0f) ||
        !std::isfinite(boxes[i].radius)) {
      throw std::invalid_argument("AgentCrowd: box " + std::to_string(i) +
                                  " has a non-finite centre or a bad radius (" +
                                  std::to_string(boxes[i].radius) + ")");
    }
    box_centres_[i] = boxes[i].centre;
    largest_box_radius_ = std::max(largest_box_radius_, boxes[i].radius);
  }
  box_grid_.rebuild(box_centres_, half_extent_, config_.grid_cell_size);
  agent_grid_.rebuild(positions_, half_extent_, config_.grid_cell_size);

  // Every agent steers from the same snapshot; only then do they all move.
  for (std::size_t i = 0; i < positions_.size(); ++i) {
    Eigen::Vector3f acceleration = Eigen::Vector3f::Zero();
    allocate(acceleration, avoidWalls(i), config_.max_acceleration);
    allocate(acceleration, avoidBoxes(i, boxes), config_.max_acceleration);
    allocate(acceleration, separation(i), config_.max_acceleration);
    allocate(acceleration, seek(i), config_.max_acceleration);
    accelerations_[i] = acceleration;
  }
  const auto dt = static_cast<float>(config_.frame_seconds);
  for (std::size_t i = 0; i < positions_.size(); ++i) {
    Eigen::Vector3f& velocity = velocities_[i];
    velocity += accelerations_[i] * dt;
    const float speed = velocity.norm();
    if (speed > config_.max_speed) velocity *= config_.max_speed / speed;
    positions_[i] += velocity * dt;
    resolvePenetrations(i, boxes);
    clampToInterior(i);
  }
  ++work_.frames;
}

std::uint64_t AgentCrowd::checksum() const {
  // Object bytes of the vectors (no padding, see the static_assert); with no
  // agents the spans are empty, never a dereferenced null.
  return fnv1a(std::as_bytes(std::span(velocities_)), fnv1a(std::as_bytes(std::span(positions_))));
}

Eigen::Vector3f AgentCrowd::seek(std::size_t agent) {
  const auto dt = static_cast<float>(config_.frame_seconds);
  seconds_on_target_[agent] += dt;
  Eigen::Vector3f to_target = targets_[agent] - positions_[agent];
  const bool reached = to_target.norm() < config_.arrival_distance;
  if (reached || seconds_on_target_[agent] > config_.retarget_seconds) {
    if (reached) ++work_.targets_reached;
    targets_[agent] = randomInteriorPoint();
    seconds_on_target_[agent] = 0.0f;
    to_target = targets_[agent] - positions_[agent];
  }
  if (to_target.norm() < kTinyLength) return Eigen::Vector3f::Zero();
  const Eigen::Vector3f desired_velocity = to_target.normalized() * config_.max_speed;
  return (desired_velocity - velocities_[agent]) / kSeekReactionSeconds;
}

Eigen::Vector3f AgentCrowd::separation(std::size_t agent) {
  const float reach = config_.separation_distance;
  if (reach <= 0.0f) return Eigen::Vector3f::Zero();
  const Eigen::Vector3f& position = positions_[agent];
  Eigen::Vector3f push = Eigen::Vector3f::Zero();
  agent_grid_.forEachNear(position, reach, [&](std::uint32_t other) {
    if (other == agent) return;
    ++work_.agent_agent_tests;
    const Eigen::Vector3f apart = position - positions_[other];
    const float distance = apart.norm();
    // Coincident agents have no direction to part in; their neighbours or
    // their different targets separate them next frame.
    if (distance >= reach || distance < kTinyLength) return;
    push += apart / distance * (1.0f - distance / reach);
  });
  return push * config_.max_acceleration;
}

Eigen::Vector3f AgentCrowd::avoidBoxes(std::size_t agent, std::span<const Obstacle> boxes) {
  const Eigen::Vector3f& position = positions_[agent];
  const Eigen::Vector3f& velocity = velocities_[agent];
  const float speed = velocity.norm();
  // At rest, the agent is about to move towards its target: look that way.
  Eigen::Vector3f forward = speed > kTinyLength ? Eigen::Vector3f(velocity / speed)
                                                : Eigen::Vector3f(targets_[agent] - position);
  if (forward.norm() < kTinyLength) return Eigen::Vector3f::Zero();
  forward.normalize();

  const float horizon = config_.max_speed * config_.look_ahead_seconds;
  float nearest_ahead = std::numeric_limits<float>::infinity();
  float nearest_reach = 0.0f;
  Eigen::Vector3f away = Eigen::Vector3f::Zero();
  box_grid_.forEachNear(position, horizon + config_.agent_radius + largest_box_radius_,
                        [&](std::uint32_t box) {
                          ++work_.agent_box_tests;
                          const Eigen::Vector3f to_box = boxes[box].centre - position;
                          const float ahead = to_box.dot(forward);
                          const float reach = horizon + boxes[box].radius;
                          if (ahead < 0.0f || ahead > reach || ahead >= nearest_ahead) return;
                          // Keep one agent radius of air between agent and box, not a graze.
                          const float clearance = boxes[box].radius + 2.0f * config_.agent_radius;
                          const Eigen::Vector3f lateral = to_box - ahead * forward;
                          const float off_course = lateral.norm();
                          if (off_course >= clearance) return;
                          nearest_ahead = ahead;
                          nearest_reach = reach;
                          away = off_course > kTinyLength ? Eigen::Vector3f(-lateral / off_course)
                                                          : perpendicularTo(forward);
                        });
  if (!std::isfinite(nearest_ahead)) return Eigen::Vector3f::Zero();
  // The nearer the threat, the harder the swerve and the braking that gives
  // the swerve room.
  const float urgency = 1.0f - nearest_ahead / nearest_reach;
  return config_.max_acceleration * (away - 0.5f * urgency * forward);
}

Eigen::Vector3f AgentCrowd::avoidWalls(std::size_t agent) const {
  const float margin = config_.wall_margin;
  if (margin <= 0.0f) return Eigen::Vector3f::Zero();
  const float limit = half_extent_ - config_.agent_radius;
  Eigen::Vector3f push = Eigen::Vector3f::Zero();
  for (int axis = 0; axis < 3; ++axis) {
    const float coordinate = positions_[agent][axis];
    const float gap_to_low = coordinate + limit;
    const float gap_to_high = limit - coordinate;
    if (gap_to_low < margin) push[axis] += 1.0f - gap_to_low / margin;
    if (gap_to_high < margin) push[axis] -= 1.0f - gap_to_high / margin;
  }
  return push * config_.max_acceleration;
}

void AgentCrowd::resolvePenetrations(std::size_t agent, std::span<const Obstacle> boxes) {
  Eigen::Vector3f& position = positions_[agent];
  Eigen::Vector3f& velocity = velocities_[agent];
  box_grid_.forEachNear(
      position, config_.agent_radius + largest_box_radius_, [&](std::uint32_t box) {
        ++work_.agent_box_tests;
        const Eigen::Vector3f from_box = position - boxes[box].centre;
        const float contact_distance = boxes[box].radius + config_.agent_radius;
        const float distance = from_box.norm();
        if (distance >= contact_distance) return;
        const Eigen::Vector3f normal = distance > kTinyLength ? Eigen::Vector3f(from_box / distance)
                                                              : Eigen::Vector3f::UnitY();
        position = boxes[box].centre + normal * contact_distance;
        const float into_box = velocity.dot(normal);
        if (into_box < 0.0f) velocity -= into_box * normal;
        ++work_.penetrations_resolved;
      });
}

void AgentCrowd::clampToInterior(std::size_t agent) {
  const float limit = half_extent_ - config_.agent_radius;
  for (int axis = 0; axis < 3; ++axis) {
    float& coordinate = positions_[agent][axis];
    float& speed = velocities_[agent][axis];
    if (coordinate < -limit) {
      coordinate = -limit;
      speed = std::max(speed, 0.0f);
    } else if (coordinate > limit) {
      coordinate = limit;
      speed = std::min(speed, 0.0f);
    }
  }
}

Eigen::Vector3f AgentCrowd::randomInteriorPoint() {
  const double limit = half_extent_ - config_.agent_radius - config_.wall_margin;
  Eigen::Vector3f point;
  for (int axis = 0; axis < 3; ++axis) {
    point[axis] = static_cast<float>(random_.uniform(-limit, limit));
  }
  return point;
}

}  // namespace overlap::stubs
