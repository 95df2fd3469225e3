#include "engine/cli/physics_options.h"

#include <stdexcept>

#include "engine/program/number_options.h"
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
      ->check(CLI::Validator(
          [](std::string& text) {
            // K as every whole-number option takes it: "010" and " 5" are refused.
            return text == "auto" ? std::string()
                                  : wholeNumberProblem(text, 1, physics::kMostSubsteps);
          },
          "auto|K"))
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
  command
      .add_option("--solver-order", solver_order_,
                  "the contact solver's sweep: coloured (regions of boxes in batches, a batch's "
                  "regions on every thread; the same state for any --threads) or serial "
                  "(Bullet's own, in manifold order, on one thread)")
      ->check(parsedBy(physics::parseSolverOrder, "coloured|serial"))
      ->capture_default_str();
  command
      .add_option("--narrowphase", narrowphase_,
                  "how contacts are found, the same ones in every mode: beside-search (on every "
                  "thread, the cached pairs' while our finder searches), parallel (on every "
                  "thread, after the search) or bullet (Bullet's serial dispatch)")
      ->check(parsedBy(physics::parseNarrowphaseMode, "beside-search|parallel|bullet"))
      ->capture_default_str();
}

physics::WorldOptions PhysicsOptions::resolve(const std::string& algorithm,
                                              const physics::SceneConfig& config) const {
  physics::WorldOptions options{algorithm, physics::parseSubsteps(substeps_),
                                physics::parseCcdMode(ccd_), physics::parseSleepMode(sleep_),
                                physics::parseSolverMode(solver_)};
  options.solver_order = physics::parseSolverOrder(solver_order_);
  options.narrowphase = physics::parseNarrowphaseMode(narrowphase_);
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
      {"solver", physics::solverModeName(options.solver)},
      {"solver_order", physics::solverOrderName(options.solver_order)},
      {"narrowphase", physics::narrowphaseModeName(options.narrowphase)}};
}

}  // namespace overlap::engine
