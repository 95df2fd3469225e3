// What a run models, the options every scene-stepping subcommand shares:
//   --substeps auto|K     K chosen each frame (physics/step_policy.h) or fixed
//   --ccd off|auto|all    Bullet's swept-sphere CCD: none, the boxes that need
//                         it this frame, every box
//   --sleep scene|on|off  Bullet's deactivation (scene: on for scenes 1-2)
//   --solver pile|bullet  Bullet's contact solver settings (physics/step_policy.h)
//   --solver-order coloured|serial  its sweep: coloured batches on every
//                         thread (physics/coloured_solver.h) or Bullet's serial one
//   --narrowphase beside-search|parallel|bullet
//                         how the narrowphase runs (physics/parallel_dispatcher.h);
//                         the same contacts in every mode
// Kept apart from scene_options.* so the scene's numbers and the model's
// choices can change independently.
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>

#include "physics/world.h"

namespace overlap::engine {

class PhysicsOptions {
 public:
  // Registers --substeps, and unless `substeps_only` also --ccd, --sleep,
  // --solver, --solver-order and --narrowphase.
  void addTo(CLI::App& command, bool substeps_only = false);
  // The world options the parsed text describes; throws UsageError when the
  // scene does not allow them (--sleep on where gravity turns).
  physics::WorldOptions resolve(const std::string& algorithm,
                                const physics::SceneConfig& config) const;

 private:
  std::string substeps_ = "auto";
  std::string ccd_ = "auto";
  std::string sleep_ = "scene";
  std::string solver_ = "pile";
  std::string solver_order_ = "coloured";
  std::string narrowphase_ = "beside-search";
};

// summary.json's record of what the run modelled.
nlohmann::json toJson(const physics::WorldOptions& options);

}  // namespace overlap::engine
