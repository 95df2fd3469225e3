#include "gpu/pair_finder.h"

#include <limits>
#include <stdexcept>
#include <string>

#include "gpu/base/shown_value.h"
#include "gpu/base/stopwatch.h"

namespace overlap::finders {

void PairFinder::launch(std::span<const ObjectBounds> objects) {
  start(objects, nullptr);
}

void PairFinder::launchWithChanges(std::span<const ObjectBounds> objects,
                                   std::span<const std::uint32_t> changed) {
  start(objects, &changed);
}

PairLimitError::PairLimitError(std::string_view finder, std::uint64_t most)
    : std::runtime_error(std::string(finder) + ": a frame has more than the pair limit's " +
                         std::to_string(most) + " pairs"),
      most_pairs(most) {}

void PairFinder::setPairLimit(std::uint64_t most_pairs) {
  if (in_flight_) {
    throw std::runtime_error(std::string(name()) +
                             ": setPairLimit() called between launch() and finish()");
  }
  pair_limit_ = most_pairs == 0 ? UINT64_MAX : most_pairs;
}

void PairFinder::start(std::span<const ObjectBounds> objects,
                       const std::span<const std::uint32_t>* changed) {
  if (in_flight_) {
    throw std::runtime_error(std::string(name()) + ": launch() called twice without finish()");
  }
  if (spent_) throw *spent_;
  launched_at_ = SteadyClock::now();
  startSearch(objects, changed);
  in_flight_ = true;
}

PairDelta PairFinder::finish() {
  if (!in_flight_) {
    throw std::runtime_error(std::string(name()) + ": finish() called without launch()");
  }
  in_flight_ = false;
  PairDelta delta;
  try {
    delta = finishSearch();
  } catch (const PairLimitError& refusal) {
    spent_ = refusal;
    throw;
  }
  launch_to_finish_ms_ = msSinceLaunch();
  return delta;
}

std::span<ObjectBounds> PairFinder::stagingFor(std::size_t count) {
  if (in_flight_) {
    throw std::runtime_error(std::string(name()) +
                             ": stagingFor() called between launch() and finish()");
  }
  return staging(count);
}

SearchStats PairFinder::lastStats() const {
  SearchStats stats = searchStats();
  stats.launch_to_finish_ms = launch_to_finish_ms_;
  return stats;
}

double PairFinder::msSinceLaunch() const {
  return toMilliseconds(SteadyClock::now() - launched_at_);
}

const PairFinderRow& pairFinderRow(std::string_view name, std::span<const PairFinderRow> table) {
  for (const PairFinderRow& row : table) {
    if (row.name == name) return row;
  }
  throw std::invalid_argument("pair finder: unknown name '" + shownValue(name) + "'");
}

std::unique_ptr<PairFinder> makePairFinder(std::string_view name, TaskSystem& tasks,
                                           std::span<const PairFinderRow> table) {
  const PairFinderRow& row = pairFinderRow(name, table);
  if (row.needs_device) {
    std::string why;
    if (!cudaDeviceAvailable(&why)) {
      throw std::runtime_error("makePairFinder: the GPU pair finders need a CUDA device: " + why);
    }
  }
  return row.make(tasks);
}

std::uint32_t checkedSlotCount(std::string_view finder, std::uint32_t previous,
                               std::size_t objects) {
  const std::string name(finder);
  if (objects < previous) {
    throw std::runtime_error(name + ": slot count shrank from " + std::to_string(previous) +
                             " to " + std::to_string(objects));
  }
  if (objects > std::numeric_limits<std::uint32_t>::max()) {
    throw std::runtime_error(name + ": " + std::to_string(objects) +
                             " slots do not fit 32-bit slot indices");
  }
  return static_cast<std::uint32_t>(objects);
}

}  // namespace overlap::finders
