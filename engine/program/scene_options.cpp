#include "engine/program/scene_options.h"

#include <oneapi/tbb/info.h>

#include <algorithm>
#include <cerrno>  // program_invocation_short_name
#include <cstdio>
#include <stdexcept>
#include <string_view>
#include <tuple>

#include "engine/program/choice_options.h"
#include "engine/program/number_options.h"
#include "engine/program/usage_error.h"
#include "physics/broadphase/broadphase_factory.h"
#include "physics/broadphase/default_broadphase.h"

namespace overlap::engine {
namespace {

CLI::Option* addSizeRange(CLI::App& command, const std::string& name, std::vector<double>& range,
                          const physics::SizeRange& paper, const std::string& what) {
  return command.add_option(name, range, "scene 4: " + what + " edge factor range LO HI")
      ->expected(2)
      ->check(realNumberIn(physics::kSmallestEdge, physics::kLargestEdge))
      ->default_str(CLI::detail::to_string(paper.lo) + " " + CLI::detail::to_string(paper.hi));
}

physics::SizeRange rangeOr(const std::vector<double>& given, const physics::SizeRange& paper) {
  return given.empty() ? paper : physics::SizeRange{given[0], given[1]};
}

}  // namespace

void SceneOptions::addTo(CLI::App& command, int objects) {
  config_.objects = objects;
  command
      .add_option("--scene", config_.scene, "1 fall, 2 kicks, 3 rotating gravity, 4 mixed sizes")
      ->check(wholeNumberIn(1, 4))
      ->capture_default_str();
  objects_option_ = command.add_option("--objects,-n", config_.objects, "dynamic boxes")
                        ->check(wholeNumberIn(1, kMostObjects))
                        ->capture_default_str();
  command.add_option("--seed", config_.seed, "seed of the start state (and scene 2's kicks)")
      ->check(seedNumber())
      ->capture_default_str();
  command.add_option("--fill", config_.fill_fraction, "share of the interior the boxes fill")
      ->check(realNumberIn(1e-6, 0.3))
      ->capture_default_str();
  command.add_option("--wall-min", config_.wall_min_thickness, "minimum wall thickness (m)")
      ->check(realNumberIn(0, kMostReal, true))
      ->capture_default_str();
  command
      .add_option("--wall-fraction", config_.wall_fraction,
                  "wall thickness as a share of the interior edge")
      ->check(realNumberIn(0, kMostReal))
      ->capture_default_str();
  command
      .add_option("--initial-speed", config_.initial_speed,
                  "start velocity components uniform in [-v, v] m/s")
      ->check(realNumberIn(0, kMostReal))
      ->capture_default_str();
  command.add_option("--frame-time", config_.frame_time, "seconds of animation per frame")
      ->check(realNumberIn(1e-6, 1.0))
      ->capture_default_str();
  command.add_option("--gravity", config_.g, "g in m/s^2")
      ->check(realNumberIn(0, kMostReal))
      ->capture_default_str();
  command.add_option("--gravity-scale", gravity_scale_, "gravity in g")
      ->check(realNumberIn(0, kMostReal))
      ->default_str("1 for scenes 1-2, 50 for scenes 3-4");
  using Config = const physics::SceneConfig&;
  scene_specific_ = {
      {command.add_option("--kicks", config_.kicks_per_frame, "scene 2: objects kicked per frame")
           ->check(wholeNumberIn(0, kMostObjects))
           ->capture_default_str(),
       [](Config c) { return c.kicks(); }, "scene 2"},
      {command
           .add_option("--rotation", config_.rotation_per_frame,
                       "scenes 3-4: gravity rotation per frame (rad)")
           ->check(realNumberIn(-kMostReal, kMostReal))
           ->capture_default_str(),
       [](Config c) { return c.rotatingGravity(); }, "scenes 3-4"},
  };
  for (auto [name, range, paper, what] :
       {std::tuple{"--small-sizes", &small_, config_.small, "small"},
        std::tuple{"--average-sizes", &average_, config_.average, "average"},
        std::tuple{"--large-sizes", &large_, config_.large, "large"}}) {
    scene_specific_.push_back({addSizeRange(command, name, *range, paper, what),
                               [](Config c) { return c.mixedSizes(); }, "scene 4"});
  }
}

physics::SceneConfig SceneOptions::resolve() const {
  physics::SceneConfig config = config_;
  for (const SceneSpecific& option : scene_specific_) {
    if (option.option->count() > 0 && !option.used_by(config)) {
      throw UsageError(option.option->get_name() + ": scene " + std::to_string(config.scene) +
                       " does not use it (" + option.scenes + " only)");
    }
  }
  config.gravity_scale =
      gravity_scale_.value_or(physics::SceneConfig::forScene(config.scene).gravity_scale);
  config.small = rangeOr(small_, config_.small);
  config.average = rangeOr(average_, config_.average);
  config.large = rangeOr(large_, config_.large);
  try {
    config.validate();
  } catch (const std::invalid_argument& error) {
    throw UsageError(std::string("--") + error.what());
  }
  return config;
}

nlohmann::json toJson(const physics::SceneConfig& config) {
  auto range = [](const physics::SizeRange& r) { return nlohmann::json::array({r.lo, r.hi}); };
  return {{"scene", config.scene},
          {"objects", config.objects},
          {"seed", config.seed},
          {"fill", config.fill_fraction},
          {"wall_min", config.wall_min_thickness},
          {"wall_fraction", config.wall_fraction},
          {"initial_speed", config.initial_speed},
          {"frame_time", config.frame_time},
          {"gravity", config.g},
          {"gravity_scale", config.gravity_scale},
          {"kicks", config.kicks_per_frame},
          {"rotation", config.rotation_per_frame},
          {"small_sizes", range(config.small)},
          {"average_sizes", range(config.average)},
          {"large_sizes", range(config.large)}};
}

std::string defaultAlgorithmRule() {
  return "the box-count rule: with a CUDA device cpubf below " +
         std::to_string(physics::kGpubfFrom) + " boxes, gpubf below " +
         std::to_string(physics::kGpusapFrom) + ", gpusap from there; without one " +
         std::string(physics::kDeviceFallback);
}

void addAlgorithmOption(CLI::App& command, std::optional<std::string>& algorithm) {
  command
      .add_option("--algo", algorithm,
                  "broadphase: " + broadphaseNameList() +
                      " (`overlap --list-algos` says what each is; a device one without a "
                      "CUDA device runs " +
                      std::string(physics::kDeviceFallback) + " and says so)")
      ->check(broadphaseNameCheck())
      ->default_str(defaultAlgorithmRule());
}

ChosenAlgorithm chooseAlgorithm(const std::optional<std::string>& algorithm, int objects) {
  if (algorithm) return {*algorithm, {}};
  physics::DefaultBroadphase pick =
      physics::defaultBroadphaseHere(static_cast<std::size_t>(objects));
  return {std::string(pick.name), std::move(pick.reason)};
}

void checkBroadphaseCapacity(std::string_view option, std::string_view algorithm, int objects) {
  if (const std::string problem = physics::broadphaseCapacityProblem(algorithm, objects);
      !problem.empty()) {
    throw UsageError(std::string(option) + " " + std::string(algorithm) + ": " + problem);
  }
}

CLI::Validator broadphaseNameCheck() {
  return oneOf(std::vector<std::string>(physics::broadphaseNames().begin(),
                                        physics::broadphaseNames().end()));
}

std::string broadphaseNameList() {
  std::string list;
  for (const std::string_view name : physics::broadphaseNames()) {
    list += (list.empty() ? "" : ", ") + std::string(name);
  }
  return list;
}

void addThreadsOption(CLI::App& command, int& threads) {
  command
      .add_option("--threads", threads,
                  "threads the run uses, the main thread included: it runs Bullet, N - 1 oneTBB "
                  "workers run the tasks and cpubf's search (0: one per hardware thread)")
      ->check(wholeNumberIn(0, kMostThreads))
      ->capture_default_str();
}

RunThreads runThreads(int threads) {
  RunThreads run;
  if (threads > 0) {
    run.cap.emplace(tbb::global_control::max_allowed_parallelism,
                    static_cast<std::size_t>(threads));
  }
  const int in_use = threadsInUse();
  if (threads > in_use) {  // said, never cut silently: the summary's count is not the asked one
    std::fprintf(stderr,
                 "%s: --threads %d: this machine runs at most %d (its hardware threads); "
                 "the run uses %d\n",
                 program_invocation_short_name, threads, in_use, in_use);
  }
  run.tasks = makeTaskSystem(in_use);
  return run;
}

int threadsInUse() {
  const auto cap = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  return static_cast<int>(
      std::min(cap, static_cast<std::size_t>(std::max(1, tbb::info::default_concurrency()))));
}

}  // namespace overlap::engine
