// overlap_gpu_frame_cost: what one steady frame of each GPU finder asks of
// the device, counted by the CUDA emulation (calls, copies, bytes over the
// bus; never a time), and the finder's own count of its host work
// (PairFinder::lastStats().device: bytes memcpy'd and entries sorted on the
// host).  Run by scripts/gpu_kernel_cost.sh.
//   overlap_gpu_frame_cost [N...]     (default 3500)
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "gpu/base/standard_streams.h"
#include "gpu/pair_finder.h"
#include "tests/gpu/frame_cost.h"

int main(int argc, char** argv) {
  overlap::holdStandardStreams();  // first: before anything opens a file
  using namespace overlap::finders;
  std::vector<std::uint32_t> sizes;
  for (int i = 1; i < argc; ++i) {
    char* end = nullptr;
    const unsigned long n = std::strtoul(argv[i], &end, 10);
    if (*end != '\0' || n < 2 || n > 100000) {
      std::fprintf(stderr, "overlap_gpu_frame_cost: N '%s' must be a whole number in 2..100000\n",
                   argv[i]);
      return 2;
    }
    sizes.push_back(static_cast<std::uint32_t>(n));
  }
  if (sizes.empty()) sizes.push_back(3500);
  std::printf("%-12s %6s %9s %8s %7s %7s %7s %7s %14s %12s %7s %6s %12s %11s\n", "finder", "n",
              "api_calls", "launches", "uploads", "copies", "d2d", "memsets", "bytes_to_dev",
              "bytes_to_host", "events", "waits", "host_copied", "host_sorted");
  for (const std::uint32_t n : sizes) {
    for (const PairFinderRow& row : pairFinderTable()) {
      if (!row.needs_device) continue;
      const auto finder = makePairFinder(row.name);
      const auto c = testing::steadyFrameCost(*finder, n);
      const DeviceWork work = finder->lastStats().device;
      std::printf(
          "%-12s %6u %9llu %8llu %7llu %7llu %7llu %7llu %14llu %12llu %7llu %6llu %12llu %11llu\n",
          std::string(finder->name()).c_str(), n, static_cast<unsigned long long>(c.api_calls),
          static_cast<unsigned long long>(c.kernel_launches),
          static_cast<unsigned long long>(c.copies_to_device),
          static_cast<unsigned long long>(c.copies_to_host),
          static_cast<unsigned long long>(c.copies_on_device),
          static_cast<unsigned long long>(c.memsets),
          static_cast<unsigned long long>(c.bytes_to_device),
          static_cast<unsigned long long>(c.bytes_to_host),
          static_cast<unsigned long long>(c.event_records),
          static_cast<unsigned long long>(c.host_waits),
          static_cast<unsigned long long>(work.host_bytes_copied),
          static_cast<unsigned long long>(work.host_entries_sorted));
    }
  }
  return 0;
}
