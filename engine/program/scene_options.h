// The options the scene-driven subcommands share (run, record, capture,
// latency), named like docs/SCENES.md's numbers, each defaulting to the paper's
// value, and the --algo option of run, capture and pairs (record has none
// and latency takes a list; both step the scene with bvh).  Defaults that
// depend on the scene (50 g for scenes 3 and 4) are resolved after parsing,
// so `--scene 3 --gravity-scale 10` still works.  An option only some scenes
// use (--kicks: scene 2) given to another scene is a UsageError, not ignored.
#pragma once

#include <oneapi/tbb/global_control.h>

#include <CLI/CLI.hpp>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "gpu/task_system.h"
#include "physics/scene.h"

namespace overlap::engine {

// The documented upper bounds of the counts (docs/CLI.md, "Bounds").
inline constexpr int kMostObjects = 10'000'000;
inline constexpr int kMostFrames = 1'000'000;
inline constexpr int kMostThreads = 1024;

class SceneOptions {
 public:
  // Registers --scene, --objects, --seed and the scene's numbers on `command`;
  // --objects defaults to `objects` (the paper's 3500 unless told).
  void addTo(CLI::App& command, int objects = physics::SceneConfig{}.objects);
  // The config the parsed options describe; throws UsageError if invalid.
  physics::SceneConfig resolve() const;
  bool objectsGiven() const { return objects_option_ != nullptr && objects_option_->count() > 0; }

 private:
  // An option that only some scenes read, and what `command` made of it.
  struct SceneSpecific {
    CLI::Option* option;
    bool (*used_by)(const physics::SceneConfig&);
    const char* scenes;  // "scene 2", for the message
  };

  physics::SceneConfig config_;
  std::optional<double> gravity_scale_;
  std::vector<double> small_, average_, large_;
  std::vector<SceneSpecific> scene_specific_;
  CLI::Option* objects_option_ = nullptr;
};

nlohmann::json toJson(const physics::SceneConfig& config);

// Every subcommand's --algo default, as --help shows it: the box-count rule
// of physics/broadphase/default_broadphase.h ("the box-count rule: cpubf below 500
// boxes, ...").
std::string defaultAlgorithmRule();

// Registers --algo, checked against the broadphases' names; left unset, the
// box-count rule picks (chooseAlgorithm).
void addAlgorithmOption(CLI::App& command, std::optional<std::string>& algorithm);

// The broadphase a run of `objects` boxes uses: the one --algo named, or
// the box-count rule's pick with its one-line reason (empty when named).
struct ChosenAlgorithm {
  std::string name;
  std::string default_reason;
};
ChosenAlgorithm chooseAlgorithm(const std::optional<std::string>& algorithm, int objects);

// Registers --threads: every thread the run uses, the main thread included
// (0: one per hardware thread).  --substeps, --ccd and --sleep are
// engine/cli/physics_options.h's.
void addThreadsOption(CLI::App& command, int& threads);

// Throws UsageError naming `option` when broadphase `algorithm` cannot hold
// `objects` boxes (sap's limit), before any work.
void checkBroadphaseCapacity(std::string_view option, std::string_view algorithm, int objects);

// The check for any option that names broadphases (--algo, --algos).
CLI::Validator broadphaseNameCheck();
// "bf, sap, ..., gpubf-paper": every name --algo takes.
std::string broadphaseNameList();

// A run's threads, for as long as it lives: oneTBB capped at `threads`
// (0: oneTBB's default), and the one task system of threadsInUse() threads
// that the run hands to everything parallel (the step, the finders, the
// tasks), so --threads N caps the whole run.  oneTBB runs no more threads
// than the machine has: a larger N is cut to that, and stderr says so.
struct RunThreads {
  std::optional<tbb::global_control> cap;
  std::unique_ptr<TaskSystem> tasks;
};
RunThreads runThreads(int threads);

// The threads a run uses under the cap in force, the main thread included:
// the smaller of the cap and oneTBB's default concurrency (the hardware
// threads this process may run on), so --threads 0 gives the machine's
// count and --threads beyond it the count that can run.  The one source of
// a summary's "threads".
int threadsInUse();

}  // namespace overlap::engine
