// `overlap latency`: what a broadphase one frame late costs and saves.
//
// A broadphase that searches last frame's AABBs can run during the whole
// previous physics step instead of inside this one, but it answers for boxes
// that have moved since.  Growing each box's last AABB by growth * |v| * dt on
// every side (v: the box's linear velocity after last frame, dt: one frame)
// covers a box that keeps its velocity; gravity, collisions and rotation
// during the frame are what the growth does not cover, and the missed pairs
// measure them.  v is read from Bullet's bodies when last frame ends, which
// is what a late search launched then has at hand (no estimate from the
// displacement of the AABBs is needed).
//
// The scene runs once with bvh and the scene's substeps (the trajectory of
// `overlap record`), whatever broadphases are studied.  After each frame f,
// the exact pairs of the boxes' new AABBs (btSimpleBroadphase, the oracle) are
// compared with the pairs each studied broadphase finds in the grown AABBs of
// the frame before; the same broadphase's on-time search of the new AABBs is
// timed beside the late one.  Walls are left out, as in `.aabbs` streams.
// Printed on stdout as CSV, one row per frame, broadphase and growth:
//   frame, algo (the one that ran), growth, exact_pairs, on_time_pairs,
//   late_pairs, missed (exact, not late), extra (late, not exact),
//   on_time_ms, late_ms (writing the AABBs plus finding the pairs).
//
// Invariant: an on-time search never misses an exact pair (every broadphase
// here is exact or conservative); if one does, the command fails.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/cli/commands.h"
#include "engine/cli/physics_options.h"
#include "engine/cli/world_setup.h"
#include "engine/program/csv.h"
#include "engine/program/list_options.h"
#include "engine/program/number_options.h"
#include "engine/program/progress.h"
#include "engine/program/scene_options.h"
#include "engine/program/summary_output.h"
#include "engine/program/wording.h"
#include "engine/runtime/game_session.h"
#include "engine/runtime/run_summary.h"
#include "engine/runtime/statistics.h"
#include "gpu/base/output_file.h"
#include "gpu/base/stopwatch.h"
#include "physics/aabb_stream.h"
#include "physics/broadphase_replay.h"
#include "physics/world.h"

namespace overlap::engine {
namespace {

using Pairs = physics::PairList;

// --growth's bound: a thousand frames' motion already covers the world.
constexpr double kMostGrowth = 1000.0;

struct LatencyOptions {
  SceneOptions scene;
  std::vector<std::string> algorithms;  // empty: the box-count rule's pick
  std::vector<double> growths = {1.0};
  int frames = 2048;
  PhysicsOptions physics;
  int threads = 0;  // 0: every hardware thread
  bool quiet = false;
};

// One late search's frames added up: what the summary's table shows.
struct LateTotals {
  long long exact = 0;
  long long missed = 0;
  long long extra = 0;
  std::vector<double> on_time_ms;
  std::vector<double> late_ms;

  void add(std::size_t exact_pairs, std::size_t missed_pairs, std::size_t extra_pairs,
           double on_time, double late) {
    exact += static_cast<long long>(exact_pairs);
    missed += static_cast<long long>(missed_pairs);
    extra += static_cast<long long>(extra_pairs);
    on_time_ms.push_back(on_time);
    late_ms.push_back(late);
  }
};

// The summary: the step's frames, then a row per broadphase and growth.
void printLatencySummary(const LatencyOptions& options, const physics::SceneConfig& config,
                         const FrameSummary& frames, const std::vector<std::string>& names,
                         const std::vector<LateTotals>& totals) {
  std::vector<std::vector<std::string>> table = {
      {"algo", "growth", "exact", "missed", "extra", "on-time ms", "late ms"}};
  for (std::size_t s = 0; s < names.size(); ++s) {
    for (std::size_t g = 0; g < options.growths.size(); ++g) {
      const LateTotals& late = totals[s * options.growths.size() + g];
      table.push_back({names[s], exactNumber(options.growths[g]), std::to_string(late.exact),
                       std::to_string(late.missed), std::to_string(late.extra),
                       threeDigits(median(late.on_time_ms)), threeDigits(median(late.late_ms))});
    }
  }
  std::vector<std::string> lines = frames.lines();
  lines.push_back("pairs over all frames, and a frame's search (median):");
  for (const std::string& row : alignedTable(table)) lines.push_back("  " + row);
  printSummary(options.quiet,
               "overlap latency: " + counted(frames.frames(), "frame") + " of scene " +
                   std::to_string(config.scene) + ", " + std::to_string(config.objects) +
                   " boxes, stepped with bvh (a frame: its physics step)",
               lines);
}

// One studied broadphase: its on-time search and one late search per growth.
struct Studied {
  std::unique_ptr<physics::BroadphaseReplay> on_time;
  std::vector<std::unique_ptr<physics::BroadphaseReplay>> late;  // one per growth
};

struct SearchResult {
  Pairs pairs;
  double ms;  // writing the AABBs and finding the pairs
};

SearchResult search(physics::BroadphaseReplay& replay, const std::vector<physics::Aabb>& boxes,
                    int frame) {
  const HostStopwatch watch;
  replay.update(boxes);
  replay.findPairs([frame] { return "frame " + std::to_string(frame) + ", a pair search"; });
  const double ms = watch.ms();
  return {replay.pairs(), ms};
}

struct FrameSearches {
  SearchResult on_time;
  std::vector<SearchResult> late;  // one per growth
};

// One frame's searches for one broadphase.  Whichever search runs first after
// the physics step can pay for waking a sleeping worker thread (cpubf's), so
// the order rotates from frame to frame and no one search always pays it.
FrameSearches searchAll(Studied& studied, const std::vector<physics::Aabb>& now,
                        const std::vector<std::vector<physics::Aabb>>& late_boxes, int frame) {
  FrameSearches result;
  result.late.resize(late_boxes.size());
  const std::size_t count = late_boxes.size() + 1;
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t which = (k + static_cast<std::size_t>(frame)) % count;
    if (which == 0) {
      result.on_time = search(*studied.on_time, now, frame);
    } else {
      result.late[which - 1] = search(*studied.late[which - 1], late_boxes[which - 1], frame);
    }
  }
  return result;
}

// The boxes' AABBs (walls dropped).  A box that has left the simulation is
// parked as a recorded stream stores it (physics::parkedBox): it pairs with
// nothing from then on, and a late search that still has it at its last
// AABB counts its pairs as extra.
std::vector<physics::Aabb> boxAabbs(const physics::PhysicsWorld& world,
                                    const physics::Aabb& bounds) {
  std::vector<physics::Aabb> all = world.aabbs();
  all.resize(static_cast<std::size_t>(world.config().objects));
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (!std::isfinite(all[i].min[0]) || !std::isfinite(all[i].max[0])) {
      all[i] = physics::parkedBox(bounds, static_cast<int>(i), world.config().objects);
    }
  }
  return all;
}

std::vector<physics::Aabb> grown(std::vector<physics::Aabb> boxes, const std::vector<float>& speeds,
                                 float seconds) {
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const float reach = speeds[i] * seconds;
    for (int axis = 0; axis < 3; ++axis) {
      boxes[i].min[axis] -= reach;
      boxes[i].max[axis] += reach;
    }
  }
  return boxes;
}

void measureLatency(const LatencyOptions& options) {
  const physics::SceneConfig config = options.scene.resolve();
  std::vector<std::string> algorithms = options.algorithms;
  if (algorithms.empty()) {
    const ChosenAlgorithm chosen = chooseAlgorithm(std::nullopt, config.objects);
    std::fprintf(stderr, "overlap: %s\n", chosen.default_reason.c_str());
    algorithms.push_back(chosen.name);
  }
  for (const std::string& requested : algorithms) {
    checkBroadphaseCapacity("--algo", requested, config.objects);
  }
  const RunThreads threads = runThreads(options.threads);
  physics::WorldOptions world_options = options.physics.resolve("bvh", config);
  world_options.tasks = threads.tasks.get();
  GameSession session(makeWorld(config, world_options), {});
  const physics::PhysicsWorld& world = session.world();
  const auto outer = static_cast<float>(world.layout().outerHalfExtent());
  const physics::Aabb bounds{{-outer, -outer, -outer}, {outer, outer, outer}};

  TaskSystem& tasks = *threads.tasks;
  physics::BroadphaseReplay oracle("bf", bounds, config.objects, tasks);
  std::vector<Studied> studied;
  std::vector<std::string> names;
  for (const std::string& requested : algorithms) {
    Studied entry;
    entry.on_time =
        std::make_unique<physics::BroadphaseReplay>(requested, bounds, config.objects, tasks);
    const std::string& name = entry.on_time->algorithm();
    if (!entry.on_time->notice().empty()) {
      std::fprintf(stderr, "overlap: %s\n", entry.on_time->notice().c_str());
    }
    if (std::find(names.begin(), names.end(), name) != names.end()) {
      std::fprintf(stderr, "overlap: latency: %s runs %s, already studied; skipped\n",
                   requested.c_str(), name.c_str());
      continue;
    }
    for (std::size_t g = 0; g < options.growths.size(); ++g) {
      entry.late.push_back(
          std::make_unique<physics::BroadphaseReplay>(requested, bounds, config.objects, tasks));
    }
    names.push_back(name);
    studied.push_back(std::move(entry));
  }

  std::ostringstream csv;
  csv << "frame,algo,growth,exact_pairs,on_time_pairs,late_pairs,missed,extra,on_time_ms,"
         "late_ms\n";
  const auto frame_time = static_cast<float>(config.frame_time);
  std::vector<physics::Aabb> last = boxAabbs(world, bounds);
  std::vector<float> last_speeds = world.boxSpeeds();
  FrameSummary frames(config.frame_time);
  std::vector<LateTotals> totals(studied.size() * options.growths.size());
  Progress progress("overlap latency", options.frames);
  session.runFrames(options.frames, [&](int frame, const ScheduledFrame& scheduled) {
    frames.add(scheduled.physics.timings.total_ms, scheduled.physics.timings);
    const std::vector<physics::Aabb> now = boxAabbs(world, bounds);
    const Pairs exact = search(oracle, now, frame).pairs;
    std::vector<std::vector<physics::Aabb>> late_boxes;  // one per growth
    for (const double growth : options.growths) {
      late_boxes.push_back(grown(last, last_speeds, static_cast<float>(growth) * frame_time));
    }
    for (std::size_t s = 0; s < studied.size(); ++s) {
      const FrameSearches searches = searchAll(studied[s], now, late_boxes, frame);
      if (const std::size_t missed = physics::countMissing(exact, searches.on_time.pairs);
          missed > 0) {
        throw std::runtime_error("latency: " + names[s] + " missed " + std::to_string(missed) +
                                 " exact pairs on time at frame " + std::to_string(frame));
      }
      for (std::size_t g = 0; g < options.growths.size(); ++g) {
        const SearchResult& late = searches.late[g];
        const std::size_t missed = physics::countMissing(exact, late.pairs);
        const std::size_t extra = physics::countMissing(late.pairs, exact);
        totals[s * options.growths.size() + g].add(exact.size(), missed, extra, searches.on_time.ms,
                                                   late.ms);
        csv << frame << ',' << csvField(names[s]) << ',' << exactNumber(options.growths[g]) << ','
            << exact.size() << ',' << searches.on_time.pairs.size() << ',' << late.pairs.size()
            << ',' << missed << ',' << extra << ',' << searches.on_time.ms << ',' << late.ms
            << '\n';
      }
    }
    last = now;
    last_speeds = world.boxSpeeds();
    progress.update(frame + 1);
  });
  progress.finish();
  writeStandardOutput(csv.str());
  printLatencySummary(options, config, frames, names, totals);
}

}  // namespace

void addLatencyCommand(CLI::App& app) {
  auto options = std::make_shared<LatencyOptions>();
  CLI::App* command = app.add_subcommand(
      "latency",
      "a broadphase one frame late on AABBs grown by |v| dt: per-frame CSV of the pairs it "
      "misses and adds, and its time against the on-time search");
  options->scene.addTo(*command);
  addListOption(*command, "--algo", options->algorithms, broadphaseNameCheck(),
                "broadphases studied, comma-separated: " + broadphaseNameList())
      ->default_str(defaultAlgorithmRule());
  addListOption(*command, "--growth", options->growths, realNumberIn(0, kMostGrowth),
                "late AABBs grow by GROWTH * |v| * frame time on every side; comma-separated");
  command->add_option("--frames", options->frames, "frames to run, each --frame-time long")
      ->check(wholeNumberIn(1, kMostFrames))
      ->capture_default_str();
  options->physics.addTo(*command);
  addThreadsOption(*command, options->threads);
  addQuietFlag(*command, options->quiet);
  command->footer(
      "Example:\n"
      "  overlap latency --scene 4 --objects 1000 --frames 60 --algo bvh,cpubf --growth 0,1,2 "
      "> latency.csv");
  command->callback([options] { measureLatency(*options); });
}

}  // namespace overlap::engine
