#include "engine/cli/physics_options.h"

#include <stdexcept>

#include "engine/program/usage_error.h"

namespace overlap::engine {
namespace {

// A CLI11 check from one of step_policy's parsers: its message, or "" if valid.
template <typename Parse>
CLI::Validator parsedBy(Parse parse, const std::string& description) {
  return CLI::Validator(
      [parse](std::string& text) {
        try {
          parse(text);
        } catch (const std::invalid_argument& error) {
          return std::string(error.what());
        }
        return std::string();
      },
      description);
}

}  // namespace

void PhysicsOptions::addTo(CLI::App& command, bool substeps_only) {
  command
      .add_option("--substeps", substeps_,
                  "steps per frame: auto (chosen each frame from the boxes' speeds, the walls "
                  "and gravity) or a fixed K")
      ->check(parsedBy(physics::parseSubsteps, "auto|K"))
      ->capture_default_str();
  if (substeps_only) return;
  command
      .add_option("--ccd", ccd_,
                  "Bullet's continuous collision detection: off, auto (the boxes fast for "
                  "their size this frame), all")
      ->check(parsedBy(physics::parseCcdMode, "off|auto|all"))
      ->capture_default_str();
  command
      .add_option("--sleep", sleep_,
                  "Bullet's deactivation of boxes at rest: scene (on in scenes 1-2), on, off")
      ->check(parsedBy(physics::parseSleepMode, "scene|on|off"))
      ->capture_default_str();
  command
      .add_option(
          "--solver", solver_,
          "Bullet's contact solver: pile (full warm start, overlaps corrected in the "
          "velocity solve: holds a 50 g pile at fewer substeps) or bullet (Bullet's defaults)")
      ->check(parsedBy(physics::parseSolverMode, "pile|bullet"))
      ->capture_default_str();
}

physics::WorldOptions PhysicsOptions::resolve(const std::string& algorithm,
                                              const physics::SceneConfig& config) const {
  const physics::WorldOptions options{algorithm, physics::parseSubsteps(substeps_),
                                      physics::parseCcdMode(ccd_), physics::parseSleepMode(sleep_),
                                      physics::parseSolverMode(solver_)};
  try {
    physics::sleepAllowed(config, options.sleep);
  } catch (const std::invalid_argument& error) {
    throw UsageError(std::string("--") + error.what());
  }
  return options;
}

nlohmann::json toJson(const physics::WorldOptions& options) {
  return {
      {"substeps", options.substeps == physics::kAutoSubsteps ? nlohmann::json("auto")
                                                              : nlohmann::json(options.substeps)},
      {"ccd", physics::ccdModeName(options.ccd)},
      {"sleep", physics::sleepModeName(options.sleep)},
      {"solver", physics::solverModeName(options.solver)}};
}

}  // namespace overlap::engine
