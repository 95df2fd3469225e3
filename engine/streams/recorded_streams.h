// Recorded AABB streams: `overlap record` writes them, the broadphase
// benchmark replays them from a cache on disk.
//
// A stream is what `overlap record` writes: a scene simulated with bvh and
// the default substeps, CCD and sleep, the boxes' AABBs (walls left out) at the start
// and after each of F frames, in Broadmark's `.aabbs` layout.  Recording big
// scenes takes minutes (Bullet, one thread), so each stream is kept in a
// folder under a name that says what it holds,
//   scene<S>_seed<X>_n<N>_f<F>.aabbs,
// and reused by later runs and by other machines.  The same file comes out of
// `overlap record --scene S --seed X --objects N --frames F --out <that name>`.
//
// Invariant: a stream handed out has exactly the scene name, object count and
// frame count its file name promises; a cached file whose header says
// otherwise is an error, never silently re-recorded or replayed.
#pragma once

#include <filesystem>
#include <string>

#include "engine/runtime/run_summary.h"
#include "physics/aabb_stream.h"
#include "physics/scene.h"
#include "physics/world.h"

namespace overlap::engine {

// "overlap scene S seed X, bvh, substeps auto, ccd auto, sleep scene": the
// scene name `overlap record` writes, naming the scene and how it was simulated
// (at most 127 characters, Broadmark's header field).
std::string streamSceneName(const physics::SceneConfig& config,
                            const physics::WorldOptions& options);

std::filesystem::path cachedStreamPath(const std::filesystem::path& folder,
                                       const physics::SceneConfig& config, int frames);

// Simulates `frames` frames of the scene (with `options`, by default bvh and
// the automatic substeps, CCD and sleep) and keeps the boxes' AABBs, a box
// that has left the simulation as physics::parkedBox(), with progress on
// stderr for long recordings under `label` (the program's, "overlap
// record").  `overlap record` and the benchmark both record through it;
// `summary`, if given, gets every frame's step (`overlap record`'s summary).
physics::AabbStream recordStream(const physics::SceneConfig& config, int frames,
                                 const std::string& label,
                                 const physics::WorldOptions& options = {},
                                 FrameSummary* summary = nullptr);

// Checks, before any work, that `out` can take a stream of `objects` boxes
// at the start and after each of `frames` frames: prepareOutputFile(), and
// room in its folder for the whole file (the old one stays until the new
// one is whole); UsageError naming --out otherwise.  `record` and
// `generate` both check through it.
void prepareStreamOutput(const std::filesystem::path& out, int objects, int frames);

struct CachedStream {
  physics::AabbStream stream;
  std::filesystem::path path;
  bool recorded = false;  // false: read from the cache
  double seconds = 0;     // recording or reading time
};

// Reads the cached stream, or records and caches it when there is none.
// Throws physics::AabbStreamError naming the file when a cached stream is
// corrupt or its header disagrees (the benchmark exits 2 naming it).
CachedStream loadOrRecordStream(const std::filesystem::path& folder,
                                const physics::SceneConfig& config, int frames);

}  // namespace overlap::engine
