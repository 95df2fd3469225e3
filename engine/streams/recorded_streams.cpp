#include "engine/streams/recorded_streams.h"

#include <chrono>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/program/output_checks.h"
#include "engine/program/progress.h"
#include "engine/runtime/game_session.h"
#include "physics/world.h"

namespace overlap::engine {

void prepareStreamOutput(const std::filesystem::path& out, int objects, int frames) {
  prepareOutputFile(out, "--out");
  physics::AabbStreamHeader counts;
  counts.objects = objects;
  counts.stored_frames = frames + 1;
  requireFreeSpace(out, physics::aabbStreamBytes(counts), "--out");
}

namespace {

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void checkHeader(const physics::AabbStream& stream, const std::filesystem::path& path,
                 const physics::SceneConfig& config, int frames) {
  auto mismatch = [&](const std::string& field, const std::string& found,
                      const std::string& expected) {
    throw physics::AabbStreamError(path.string() + ": cached stream's " + field + " is " + found +
                                   ", expected " + expected + "; delete it to record it again");
  };
  // The name says how the stream was simulated: a stream cached under other
  // defaults (older substeps, say) is an error, not a silent replay.
  const std::string expected = streamSceneName(config, physics::WorldOptions{});
  if (stream.scene_name != expected) {
    mismatch("scene name", '"' + stream.scene_name + '"', '"' + expected + '"');
  }
  if (stream.objects != config.objects) {
    mismatch("object count", std::to_string(stream.objects), std::to_string(config.objects));
  }
  if (stream.stored_frames != frames + 1) {
    mismatch("frame count", std::to_string(stream.stored_frames - 1), std::to_string(frames));
  }
}

}  // namespace

std::string streamSceneName(const physics::SceneConfig& config,
                            const physics::WorldOptions& options) {
  const std::string substeps =
      options.substeps == physics::kAutoSubsteps ? "auto" : std::to_string(options.substeps);
  return "overlap scene " + std::to_string(config.scene) + " seed " + std::to_string(config.seed) +
         ", " + options.algorithm + ", substeps " + substeps + ", ccd " +
         physics::ccdModeName(options.ccd) + ", sleep " + physics::sleepModeName(options.sleep) +
         ", solver " + physics::solverModeName(options.solver);
}

std::filesystem::path cachedStreamPath(const std::filesystem::path& folder,
                                       const physics::SceneConfig& config, int frames) {
  return folder /
         ("scene" + std::to_string(config.scene) + "_seed" + std::to_string(config.seed) + "_n" +
          std::to_string(config.objects) + "_f" + std::to_string(frames) + ".aabbs");
}

physics::AabbStream recordStream(const physics::SceneConfig& config, int frames,
                                 const std::string& label, const physics::WorldOptions& options,
                                 FrameSummary* summary) {
  Progress placing("overlap: placing " + std::to_string(config.objects) + " boxes", 0);
  GameSession session(std::make_unique<physics::PhysicsWorld>(config, options), {});
  placing.finish();
  const physics::PhysicsWorld& world = session.world();

  physics::AabbStream stream;
  stream.scene_name = streamSceneName(config, options);
  stream.object_type = "box";
  stream.objects = config.objects;
  stream.stored_frames = frames + 1;
  const auto outer = static_cast<float>(world.layout().outerHalfExtent());
  stream.world = physics::Aabb{{-outer, -outer, -outer}, {outer, outer, outer}};
  stream.boxes.reserve(static_cast<std::size_t>(stream.objects) * stream.stored_frames);
  auto keepBoxes = [&] {
    const std::vector<physics::Aabb> all = world.aabbs();  // boxes, then walls
    for (int i = 0; i < config.objects; ++i) {
      const physics::Aabb& box = all[static_cast<std::size_t>(i)];
      // aabbs() gives a box out of the simulation as an inverted, empty box.
      const bool left_simulation = box.min[0] > box.max[0];
      stream.boxes.push_back(left_simulation ? physics::parkedBox(stream.world, i, config.objects)
                                             : box);
    }
  };

  Progress progress(label, frames);
  keepBoxes();
  session.runFrames(frames, [&](int frame, const ScheduledFrame& scheduled) {
    if (summary != nullptr)
      summary->add(scheduled.physics.timings.total_ms, scheduled.physics.timings);
    keepBoxes();
    progress.update(frame + 1);
  });
  progress.finish();
  return stream;
}

CachedStream loadOrRecordStream(const std::filesystem::path& folder,
                                const physics::SceneConfig& config, int frames) {
  CachedStream cached;
  cached.path = cachedStreamPath(folder, config, frames);
  const auto start = std::chrono::steady_clock::now();
  if (std::filesystem::exists(cached.path)) {
    try {
      cached.stream = physics::readAabbStream(cached.path);
    } catch (const physics::AabbStreamError& error) {
      throw physics::AabbStreamError(std::string(error.what()) + "; delete it to record it again");
    }
    checkHeader(cached.stream, cached.path, config, frames);
  } else {
    cached.stream = recordStream(
        config, frames, "overlap_bench_broadphase: recording n=" + std::to_string(config.objects));
    // The cache is the benchmark's own folder: a link planted at a stream's
    // name is replaced by the stream, never written through.
    physics::writeAabbStream(cached.path, cached.stream, FinalLink::kReplace);
    cached.recorded = true;
  }
  cached.seconds = secondsSince(start);
  return cached;
}

}  // namespace overlap::engine
