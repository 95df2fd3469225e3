// The world a scene-stepping subcommand (run, capture, latency) steps:
// physics::PhysicsWorld built from the parsed options (physics/ is the
// factory: the constructor picks the broadphase and places the boxes), shown
// as the command line shows work: a progress line while the boxes are placed,
// the world's algorithm notice on stderr, and a scene the options cannot
// build (std::invalid_argument: no room for the boxes, say) as a UsageError
// naming the option.
#pragma once

#include <memory>

#include "physics/scene.h"
#include "physics/world.h"

namespace overlap::engine {

std::unique_ptr<physics::PhysicsWorld> makeWorld(const physics::SceneConfig& config,
                                                 const physics::WorldOptions& options);

}  // namespace overlap::engine
