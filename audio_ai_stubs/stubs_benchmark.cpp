// Time per frame of the sound and AI systems at their default cost, on one
// thread, with a workload shaped like the paper's scenes: 3500 unit boxes
// filling 10% of the container, and a stream of new contacts for the mixer.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "audio_ai_stubs/ai.h"
#include "audio_ai_stubs/sound.h"
#include "physics/random.h"

namespace {

using overlap::stubs::AgentCrowd;
using overlap::stubs::AiConfig;
using overlap::stubs::ImpactEvent;
using overlap::stubs::Obstacle;
using overlap::stubs::SoundConfig;
using overlap::stubs::SoundMixer;

constexpr int kBoxes = 3500;
// Unit boxes at 10% fill: interior edge L = cbrt(3500 / 0.10).
const float kHalfExtent = static_cast<float>(std::cbrt(kBoxes / 0.10) / 2.0);
constexpr float kUnitBoxSphereRadius = 0.8660254f;  // sqrt(3)/2

std::vector<Obstacle> randomBoxes(overlap::physics::SeededRandom& random) {
  std::vector<Obstacle> boxes(kBoxes);
  for (Obstacle& box : boxes) {
    for (int axis = 0; axis < 3; ++axis) {
      box.centre[axis] = static_cast<float>(random.uniform(-kHalfExtent, kHalfExtent));
    }
    box.radius = kUnitBoxSphereRadius;
  }
  return boxes;
}

void BM_SoundFrame(benchmark::State& state) {
  SoundMixer mixer{SoundConfig{}};
  overlap::physics::SeededRandom random(7);
  std::vector<ImpactEvent> impacts(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    for (ImpactEvent& impact : impacts) {
      impact = {static_cast<float>(random.uniform(0.5, 10.0)),
                static_cast<float>(random.uniform(-1.0, 1.0)),
                static_cast<float>(random.uniform(0.5, 2.0))};
    }
    mixer.runFrame(impacts);
    benchmark::DoNotOptimize(mixer.mix().data());
  }
  state.counters["voices"] = benchmark::Counter(
      static_cast<double>(mixer.work().voice_samples) /
      (mixer.config().samplesPerFrame() * static_cast<double>(mixer.work().frames)));
}
BENCHMARK(BM_SoundFrame)->Arg(0)->Arg(20)->Arg(200)->Unit(benchmark::kMillisecond);

void BM_AiFrame(benchmark::State& state) {
  overlap::physics::SeededRandom random(7);
  const std::vector<Obstacle> boxes = randomBoxes(random);
  AgentCrowd crowd(AiConfig{}, kHalfExtent);
  for (auto _ : state) {
    crowd.runFrame(boxes);
    benchmark::DoNotOptimize(crowd.positions().data());
  }
  const auto frames = static_cast<double>(crowd.work().frames);
  state.counters["box_tests"] = static_cast<double>(crowd.work().agent_box_tests) / frames;
  state.counters["agent_tests"] = static_cast<double>(crowd.work().agent_agent_tests) / frames;
}
BENCHMARK(BM_AiFrame)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
