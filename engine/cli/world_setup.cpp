#include "engine/cli/world_setup.h"

#include <cstdio>
#include <stdexcept>
#include <string>

#include "engine/program/progress.h"
#include "engine/program/usage_error.h"

namespace overlap::engine {

std::unique_ptr<physics::PhysicsWorld> makeWorld(const physics::SceneConfig& config,
                                                 const physics::WorldOptions& options) {
  std::unique_ptr<physics::PhysicsWorld> world;
  Progress placing("overlap: placing " + std::to_string(config.objects) + " boxes", 0);
  try {
    world = std::make_unique<physics::PhysicsWorld>(config, options);
  } catch (const std::invalid_argument& error) {
    throw UsageError(std::string("--") + error.what());
  }
  placing.finish();
  if (!world->algorithmNotice().empty()) {
    std::fprintf(stderr, "overlap: %s\n", world->algorithmNotice().c_str());
  }
  return world;
}

}  // namespace overlap::engine
