// The scene options every scene-driven subcommand shares (run, record,
// capture), named like SCENES.md's numbers, each defaulting to the paper's
// value.  Defaults that depend on the scene (50 g for scenes 3 and 4) are
// resolved after parsing, so `--scene 3 --gravity-scale 10` still works.
#pragma once

#include <oneapi/tbb/global_control.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <optional>

#include "physics/scene.h"

namespace overlap::engine {

class SceneOptions {
 public:
  // Registers --scene, --objects, --seed and the scene's numbers on `command`.
  void addTo(CLI::App& command);
  // The config the parsed options describe; throws UsageError if invalid.
  physics::SceneConfig resolve() const;

 private:
  physics::SceneConfig config_;
  std::optional<double> gravity_scale_;
  std::vector<double> small_, average_, large_;
};

nlohmann::json toJson(const physics::SceneConfig& config);

// Registers --algo, checked against the broadphases' names.
void addAlgorithmOption(CLI::App& command, std::string& algorithm);

// The check for any option that names broadphases (--algo, --algos).
CLI::Validator broadphaseNameCheck();

// Caps every oneTBB pool of the process (cpubf's search, the tasks) at
// `threads` for as long as the result lives; 0 leaves oneTBB's default.
std::optional<tbb::global_control> capThreads(int threads);

}  // namespace overlap::engine
