// The summary a run ends with (docs/CLI.md, "The summary"): a few lines a
// reader takes in at a glance, drawn from the frames the run kept.  Every
// subcommand and the benchmark build theirs here; the command line prints
// them (engine/program/summary_output.h), so --quiet drops the summary and only it.
// Rules, each with its reason:
// - A frame is read as a game developer reads it: median, p95 and max, and
//   the frames over the frame time (the scene's --frame-time, 1/30 s by
//   default: the time a frame has before the game stutters).
// - The stage split is of means: means add up to the step's mean, medians
//   do not.  What the named stages leave of the step is shown as "other".
// - The broadphase's share is of the whole frame: it bounds what any
//   broadphase, on a GPU or not, could save.  Beside it, update +
//   broadphase: Bullet's sap and bvh do their search in the update, ours in
//   the broadphase, so only the sum compares them.
// - Nothing here prints or reads a clock: it turns figures into text.
#pragma once

#include <string>
#include <vector>

#include "physics/world.h"

namespace overlap::engine {

struct FrameSpread {
  double median = 0;
  double p95 = 0;
  double p99 = 0;
  double max = 0;
};

FrameSpread spreadOf(const std::vector<double>& values);

// How many of `values` are above `limit`.
int countOver(const std::vector<double>& values, double limit);

// --compare-sync's speed-up: the median sync frame over the median async
// one, and its spread over the run's repetitions of the comparison, the
// frames (each frame is stepped once sync and once async, on the same
// state): the quartiles of the frame-by-frame ratios.
struct Speedup {
  double speedup = 0;
  double frames_q1 = 0;
  double frames_median = 0;
  double frames_q3 = 0;
};

// `sync_ms` and `async_ms`: the same frames, in order.
Speedup speedupOf(const std::vector<double>& sync_ms, const std::vector<double>& async_ms);

// A run's frames: each one's whole time and its physics step's stages.
class FrameSummary {
 public:
  explicit FrameSummary(double frame_time_seconds) : frame_time_ms_(frame_time_seconds * 1e3) {}

  // One frame: `frame_ms` the whole frame (the physics step alone where a
  // frame is nothing else), `physics` its step.
  void add(double frame_ms, const physics::FrameTimings& physics);

  int frames() const { return static_cast<int>(frame_ms_.size()); }
  double frameTimeMs() const { return frame_time_ms_; }
  FrameSpread frameSpread() const { return spreadOf(frame_ms_); }
  int framesOverFrameTime() const { return countOver(frame_ms_, frame_time_ms_); }

  // Three lines: the frame, the step's stages, the broadphase's share.
  std::vector<std::string> lines() const;

 private:
  double frame_time_ms_;
  std::vector<double> frame_ms_;
  std::vector<physics::FrameTimings> stages_;
};

// "1.23": `value` with `decimals` decimals.
std::string fixedText(double value, int decimals);

// Three significant digits, never an exponent: 0.213, 3.52, 35.1, 152, 1520.
std::string threeDigits(double value);

// Rows of cells, the first the header, as lines with aligned columns, two
// spaces between them: a column whose cells all read as numbers ("-" for
// one that is missing) is right-aligned, header included; others left.
std::vector<std::string> alignedTable(const std::vector<std::vector<std::string>>& rows);

}  // namespace overlap::engine
