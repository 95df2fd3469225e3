// gpubf-paper: the GPU brute force of Serpa & Rodrigues (SBGames 2014),
// reproduced as the paper describes it, as the baseline gpubf is measured
// against.
//
// The paper's algorithm: n * n threads; thread i tests object A = i / n
// against B = i % n and, only for A < B, writes one result byte for the pair;
// every byte is copied back to the host each frame with a plain synchronous
// cudaMemcpy into ordinary (pageable) memory, where the host XORs them with
// last frame's bytes to find the pairs that appeared and disappeared.
//
// What the paper leaves unsaid, and the choices made here:
// - The byte layout: pair (A, B) is byte p(A, B) of gpu/pairs/pair_logic.h, so the
//   buffer holds exactly n (n - 1) / 2 bytes and every byte is written each
//   frame (no clearing pass is needed).
// - Buffer lifetime: device buffers are kept across frames and regrown only
//   when n grows, so allocation is not charged to every frame.
// - The upload: a synchronous cudaMemcpy of the boxes, as for the results.
// - The filter test: the paper tests AABBs only; the collision-filter test of
//   the other finders is applied too, so that all three give one answer.
// - Block size 256 and the default stream.
// launch() uploads and starts the kernel; finish() copies back and compares.
// Timed as gpubf is: the stage events of gpu/cuda/finder_device.h (search_ms
// from before the upload to after the copy back, the host's XOR and sort
// outside it), launch_to_finish_ms on the host's clock (everything).
#include <cuda_runtime.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "gpu/cuda/cuda_buffers.h"
#include "gpu/cuda/finder_device.h"
#include "gpu/cuda/launch_shape.h"
#include "gpu/pair_finder.h"
#include "gpu/pairs/pair_logic.h"

namespace overlap::finders {
namespace {

__global__ void paperPairsKernel(const ObjectBounds* __restrict__ objects, std::uint32_t n,
                                 std::uint8_t* __restrict__ results) {
  const std::uint64_t i = static_cast<std::uint64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= static_cast<std::uint64_t>(n) * n) return;
  const auto object_a = static_cast<std::uint32_t>(i / n);
  const auto object_b = static_cast<std::uint32_t>(i % n);
  if (object_a < object_b) {
    results[pair_logic::pairIndex(object_a, object_b)] =
        pair_logic::objectsPair(objects[object_a], objects[object_b]) ? 1 : 0;
  }
}

class PaperBruteForceFinder final : public PairFinder {
 public:
  PaperBruteForceFinder() = default;
  PaperBruteForceFinder(const PaperBruteForceFinder&) = delete;
  PaperBruteForceFinder& operator=(const PaperBruteForceFinder&) = delete;

  std::string_view name() const override { return "gpubf-paper"; }

 private:
  void startSearch(std::span<const ObjectBounds> objects,
                   const std::span<const std::uint32_t>* /*changed*/) override {
    device_.begin();
    const std::uint32_t slot_count = checkedSlotCount(name(), slot_count_, objects.size());
    const std::uint64_t thread_count = static_cast<std::uint64_t>(slot_count) * slot_count;
    const std::uint64_t block_count = (thread_count + kThreadsPerBlock - 1) / kThreadsPerBlock;
    if (block_count > static_cast<std::uint64_t>(std::numeric_limits<int>::max())) {
      throw std::runtime_error("gpubf-paper: " + std::to_string(slot_count) +
                               " slots need more than the 2^31 - 1 blocks of one launch");
    }
    slot_count_ = slot_count;
    const std::uint64_t pair_count = pair_logic::pairsBelow(slot_count_);
    reserveDiscarding(objects_, objects.size());
    reserveDiscarding(results_, pair_count);
    // New pairs had no overlap last frame.
    previous_.resize(pair_count, 0);
    current_.resize(pair_count);
    if (pair_count > 0) {
      device_.record(FinderDevice::kStarted);
      device_.check(
          cudaMemcpy(objects_.data(), objects.data(), objects.size_bytes(), cudaMemcpyHostToDevice),
          "cudaMemcpy");
      device_.work().bytes_to_device += objects.size_bytes();
      device_.record(FinderDevice::kUploaded);
      paperPairsKernel<<<static_cast<unsigned>(block_count), kThreadsPerBlock>>>(
          objects_.data(), slot_count_, results_.data());
      device_.launched();
      device_.record(FinderDevice::kSearched);
    }
  }

  PairDelta finishSearch() override {
    added_.clear();
    removed_.clear();
    searched_ = false;
    if (!current_.empty()) {
      device_.check(
          cudaMemcpy(current_.data(), results_.data(), current_.size(), cudaMemcpyDeviceToHost),
          "cudaMemcpy");
      device_.work().bytes_from_device += current_.size();
      device_.record(FinderDevice::kDone);
      device_.wait(FinderDevice::kDone);
      searched_ = true;
      if (!compareWithLastFrame()) throw pairLimitError();
      std::swap(current_, previous_);
    }
    // Scanning by byte index lists pairs by (b, a); the contract wants (a, b).
    std::sort(added_.begin(), added_.end());
    std::sort(removed_.begin(), removed_.end());
    device_.work().host_entries_sorted = added_.size() + removed_.size();
    device_.end();
    return PairDelta{added_, removed_};
  }

  // With no pairs there is no GPU work: zero times.
  SearchStats searchStats() const override {
    SearchStats stats;
    if (searched_) stats.search_ms = device_.lastMs(FinderDevice::kStarted, FinderDevice::kDone);
    stats.device = searched_ ? device_.lastWorkTimed() : device_.lastWork();
    return stats;
  }

  // The host side XOR, eight bytes at a time so that the unchanged majority
  // costs one comparison per eight pairs.  False, the lists left short, once
  // the frame has added more pairs than the pair limit.
  bool compareWithLastFrame() {
    const std::size_t size = current_.size();
    for (std::size_t chunk = 0; chunk < size; chunk += sizeof(std::uint64_t)) {
      if (added_.size() > pairLimit()) return false;
      const std::size_t length = std::min(sizeof(std::uint64_t), size - chunk);
      std::uint64_t now = 0;
      std::uint64_t before = 0;
      std::memcpy(&now, current_.data() + chunk, length);
      std::memcpy(&before, previous_.data() + chunk, length);
      if ((now ^ before) == 0) continue;
      for (std::size_t p = chunk; p < chunk + length; ++p) {
        if (current_[p] != previous_[p]) {
          (current_[p] != 0 ? added_ : removed_).push_back(pair_logic::pairAt(p));
        }
      }
    }
    return added_.size() <= pairLimit();
  }

  std::uint32_t slot_count_ = 0;
  bool searched_ = false;  // the last finished frame had pairs, so device work
  FinderDevice device_{FinderDevice::StreamKind::kLegacyDefault};
  DeviceBuffer<ObjectBounds> objects_;
  DeviceBuffer<std::uint8_t> results_;
  std::vector<std::uint8_t> current_;  // pageable, as in the paper
  std::vector<std::uint8_t> previous_;
  std::vector<IndexPair> added_;
  std::vector<IndexPair> removed_;
};

}  // namespace

std::unique_ptr<PairFinder> makePaperBruteForceFinder(TaskSystem& /*tasks*/) {
  return std::make_unique<PaperBruteForceFinder>();
}

}  // namespace overlap::finders
