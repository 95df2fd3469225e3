// Running a grid in the CUDA emulation.  Blocks are spread over worker OS
// threads; a block runs start to finish on one of them, each of its CUDA
// threads a fiber (Boost.Context's fcontext) on a stack of its own.  The
// block's scheduler resumes every ready fiber in turn until it finishes or
// waits at a collective; when all are done or waiting, it releases the
// collectives whose lanes have all arrived, and aborts naming block, thread
// and mask when a collective can never complete (a lane exited, or waits at a
// different collective).  Since a block's fibers share one OS thread, a
// `static thread_local` variable is per block, which is what __shared__ is.
//
// AddressSanitizer is told about every switch of stacks
// (__sanitizer_start/finish_switch_fiber): Boost.Context's fcontext does not
// do it itself (Debian's Boost 1.74 annotates only its ucontext variant).
#include "gpu/emulation/executor.h"

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <boost/context/detail/fcontext.hpp>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <mutex>
#include <new>
#include <optional>
#include <sstream>
#include <system_error>
#include <thread>
#include <vector>

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/common_interface_defs.h>
#endif

namespace overlap::cuda_emulation::detail {

namespace {

// The running fiber's coordinates (its Lane's), null outside a kernel thread.
thread_local const ThreadCoordinates* t_coordinates = nullptr;

namespace fctx = boost::context::detail;

#if defined(__SANITIZE_ADDRESS__)
constexpr std::size_t kStackBytes = 256 * 1024;  // ASan's frames are larger
void startSwitch(void** fake_stack, const void* bottom, std::size_t size) {
  __sanitizer_start_switch_fiber(fake_stack, bottom, size);
}
void finishSwitch(void* fake_stack, const void** bottom, std::size_t* size) {
  __sanitizer_finish_switch_fiber(fake_stack, bottom, size);
}
#else
constexpr std::size_t kStackBytes = 64 * 1024;
void startSwitch(void**, const void*, std::size_t) {}
void finishSwitch(void*, const void**, std::size_t*) {}
#endif

// A fiber stack with an inaccessible guard page below it, so an overflow
// faults instead of writing into the next stack.  Kept in a pool: a launch
// maps what its grid will take (reserveStacks), and each block runner takes
// one per thread of a block and gives them back.
struct Stack {
  void* bottom;  // lowest usable address
  std::size_t size;
};

class StackPool {
 public:
  // Maps stacks until `count` are free, or as many as the address space
  // (or the kernel's count of mappings: each stack and its guard page take
  // two) allows; false if fewer than `least` are then free.  Past a failure
  // that still left `least`, the pool holds no more than it did then and
  // later calls stop there: a grid that asks for more runs on fewer threads
  // instead of mapping the whole address space again at each launch.
  bool reserve(std::size_t count, std::size_t least) {
    const std::lock_guard lock(mutex_);
    count = std::max(std::min(count, most_), least);
    try {
      free_.reserve(count);  // so that no stack mapped is lost to a failing push_back
    } catch (const std::bad_alloc&) {
      return free_.size() >= least;
    }
    const std::size_t page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
    const std::size_t held = free_.size();
    while (free_.size() < count) {
      void* memory = mmap(nullptr, kStackBytes + page, PROT_READ | PROT_WRITE,
                          MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
      if (memory != MAP_FAILED && mprotect(memory, page, PROT_NONE) != 0) {
        munmap(memory, kStackBytes + page);
        memory = MAP_FAILED;
      }
      if (memory == MAP_FAILED) {
        // Give back what this call mapped past `least`, or all it mapped if
        // that is short of `least` (the launch fails; a later one tries
        // anew): the rest of the process needs mappings too.
        const bool enough = free_.size() >= least;
        while (free_.size() > (enough ? std::max(held, least) : held)) {
          munmap(static_cast<char*>(free_.back().bottom) - page, kStackBytes + page);
          free_.pop_back();
        }
        if (enough) most_ = free_.size();
        return enough;
      }
      free_.push_back(Stack{static_cast<char*>(memory) + page, kStackBytes});
    }
    return true;
  }
  // The stacks free between grids: all the pool holds.
  std::size_t held() {
    const std::lock_guard lock(mutex_);
    return free_.size();
  }
  Stack take() {
    const std::lock_guard lock(mutex_);
    if (free_.empty()) fail("a grid ran without the fiber stacks its launch reserved");
    const Stack stack = free_.back();
    free_.pop_back();
    return stack;
  }
  // Never allocates (a runner gives its stacks back as it ends): every stack
  // was once in free_, so its capacity holds them all.
  void give(const Stack& stack) {
    const std::lock_guard lock(mutex_);
    free_.push_back(stack);
  }

 private:
  std::mutex mutex_;
  std::vector<Stack> free_;
  std::size_t most_ = SIZE_MAX;  // the most stacks the pool may hold (see reserve)
};

StackPool& stackPool() {
  static StackPool pool;
  return pool;
}

enum class LaneState { kReady, kWaiting, kDone };

struct Lane {
  ThreadCoordinates coordinates;
  unsigned rank = 0;  // linear index in the block; warp rank / 32, lane rank % 32
  LaneState state = LaneState::kReady;
  fctx::fcontext_t context = nullptr;
  Stack stack{};
  void* fake_stack = nullptr;
  // The collective it waits at, and its result once released.
  Collective kind = Collective::kSyncThreads;
  unsigned mask = 0;
  std::uint64_t value = 0;
  int operand = 0;
  int width = 32;
  std::source_location site;
  std::uint64_t result = 0;
};

const char* collectiveName(Collective kind) {
  switch (kind) {
    case Collective::kSyncThreads:
      return "__syncthreads";
    case Collective::kSyncWarp:
      return "__syncwarp";
    case Collective::kBallot:
      return "__ballot_sync";
    case Collective::kAny:
      return "__any_sync";
    case Collective::kAll:
      return "__all_sync";
    case Collective::kShfl:
      return "__shfl_sync";
    case Collective::kShflUp:
      return "__shfl_up_sync";
    case Collective::kShflDown:
      return "__shfl_down_sync";
    case Collective::kShflXor:
      return "__shfl_xor_sync";
  }
  return "?";
}

std::string format(const uint3& v) {
  char text[40];
  std::snprintf(text, sizeof text, "(%u,%u,%u)", v.x, v.y, v.z);
  return text;
}

std::string hex(unsigned mask) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%08x", mask);
  return text;
}

// Runs blocks of one launch on the calling OS thread.
class BlockRunner {
 public:
  explicit BlockRunner(const KernelLaunch& launch)
      : launch_(launch), lanes_(launch.block.x * launch.block.y * launch.block.z) {
    for (Lane& lane : lanes_) lane.stack = stackPool().take();
  }
  ~BlockRunner() {
    for (const Lane& lane : lanes_) stackPool().give(lane.stack);
  }
  BlockRunner(const BlockRunner&) = delete;
  BlockRunner& operator=(const BlockRunner&) = delete;

  void run(std::uint64_t linear_block) {
    const dim3 grid = launch_.grid;
    const dim3 block = launch_.block;
    block_idx_ = uint3{static_cast<unsigned>(linear_block % grid.x),
                       static_cast<unsigned>(linear_block / grid.x % grid.y),
                       static_cast<unsigned>(linear_block / grid.x / grid.y)};
    for (unsigned rank = 0; rank < lanes_.size(); ++rank) {
      Lane& lane = lanes_[rank];
      lane.coordinates = ThreadCoordinates{
          uint3{rank % block.x, rank / block.x % block.y, rank / block.x / block.y}, block_idx_,
          block, grid};
      lane.rank = rank;
      lane.state = LaneState::kReady;
      lane.context = fctx::make_fcontext(static_cast<char*>(lane.stack.bottom) + lane.stack.size,
                                         lane.stack.size, &BlockRunner::laneEntry);
    }
    std::size_t done = 0;
    while (done < lanes_.size()) {
      for (Lane& lane : lanes_) {
        if (lane.state != LaneState::kReady) continue;
        resume(lane);
        if (lane.state == LaneState::kDone) ++done;
      }
      if (done < lanes_.size() && !releaseCollectives()) reportDeadlock();
    }
    t_coordinates = nullptr;
  }

  // Called in a lane's fiber: park it at a collective until released.
  static std::uint64_t wait(Collective kind, unsigned mask, std::uint64_t value, int operand,
                            int width, const std::source_location& site) {
    BlockRunner* runner = t_runner;
    if (runner == nullptr) {
      fail(std::string(collectiveName(kind)) + " called outside a kernel at " + where(site));
    }
    Lane& lane = *runner->current_;
    lane.kind = kind;
    lane.mask = mask;
    lane.value = value;
    lane.operand = operand;
    lane.width = width;
    lane.site = site;
    lane.state = LaneState::kWaiting;
    startSwitch(&lane.fake_stack, runner->scheduler_bottom_, runner->scheduler_size_);
    const fctx::transfer_t back = fctx::jump_fcontext(runner->scheduler_, nullptr);
    finishSwitch(lane.fake_stack, &runner->scheduler_bottom_, &runner->scheduler_size_);
    runner->scheduler_ = back.fctx;
    return lane.result;
  }

  static thread_local BlockRunner* t_runner;

 private:
  void resume(Lane& lane) {
    current_ = &lane;
    t_coordinates = &lane.coordinates;
    void* fake_stack = nullptr;
    startSwitch(&fake_stack, lane.stack.bottom, lane.stack.size);
    const fctx::transfer_t back = fctx::jump_fcontext(lane.context, &lane);
    finishSwitch(fake_stack, nullptr, nullptr);
    lane.context = back.fctx;
  }

  [[noreturn]] static void laneEntry(fctx::transfer_t from) {
    BlockRunner* runner = t_runner;
    runner->scheduler_ = from.fctx;
    finishSwitch(nullptr, &runner->scheduler_bottom_, &runner->scheduler_size_);
    Lane& lane = *static_cast<Lane*>(from.data);
    try {
      runner->launch_.run_thread();
    } catch (const std::exception& error) {
      runner->failAt(lane, std::string("threw an exception: ") + error.what());
    } catch (...) {
      runner->failAt(lane, "threw an exception");
    }
    // The scheduler may have moved on since this fiber started.
    runner = t_runner;
    lane.state = LaneState::kDone;
    startSwitch(nullptr, runner->scheduler_bottom_, runner->scheduler_size_);
    fctx::jump_fcontext(runner->scheduler_, nullptr);
    std::abort();  // a finished fiber is never resumed
  }

  std::string describeLane(const Lane& lane) const {
    return "thread " + format(lane.coordinates.thread_idx) + " (warp " +
           std::to_string(lane.rank / 32) + ", lane " + std::to_string(lane.rank % 32) + ")";
  }

  std::string describeWait(const Lane& lane) const {
    std::string text = std::string(collectiveName(lane.kind));
    if (lane.kind != Collective::kSyncThreads) text += " (mask " + hex(lane.mask) + ")";
    return text + " at " + where(lane.site);
  }

  [[noreturn]] void failAt(const Lane& lane, const std::string& problem) const {
    fail("kernel " + std::string(launch_.kernel_name) + " launched at " + where(launch_.site) +
         ", block " + format(block_idx_) + ": " + describeLane(lane) + " " + problem);
  }

  // Releases every collective whose lanes have all arrived; aborts on one that
  // waits for a lane that exited.  Returns whether it released any.
  bool releaseCollectives() {
    bool released = false;
    const std::size_t warps = (lanes_.size() + 31) / 32;
    for (std::size_t warp = 0; warp < warps; ++warp) {
      const std::size_t first = warp * 32;
      const std::size_t count = std::min<std::size_t>(32, lanes_.size() - first);
      const unsigned existing = count == 32 ? 0xFFFFFFFFu : (1u << count) - 1u;
      unsigned handled = 0;
      for (std::size_t i = 0; i < count; ++i) {
        const Lane& lane = lanes_[first + i];
        if (lane.state != LaneState::kWaiting || lane.kind == Collective::kSyncThreads ||
            (handled >> i & 1u) != 0) {
          continue;
        }
        const unsigned mask = lane.mask;
        if ((mask >> i & 1u) == 0)
          failAt(lane, "calls " + describeWait(lane) + " outside its own mask");
        if ((mask & ~existing) != 0) {
          failAt(lane, "calls " + describeWait(lane) + " naming lanes its block does not have");
        }
        bool complete = true;
        for (std::size_t j = 0; j < count; ++j) {
          if ((mask >> j & 1u) == 0) continue;
          const Lane& other = lanes_[first + j];
          if (other.state == LaneState::kDone) {
            failAt(lane, "waits at " + describeWait(lane) + " for " + describeLane(other) +
                             ", which exited");
          }
          complete = complete && other.state == LaneState::kWaiting && other.kind == lane.kind &&
                     other.mask == mask;
        }
        if (!complete) continue;
        completeWarpCollective(first, mask);
        handled |= mask;
        released = true;
      }
    }
    return releaseBlockBarrier() || released;
  }

  bool releaseBlockBarrier() {
    const Lane* waiting = nullptr;
    for (const Lane& lane : lanes_) {
      if (lane.state == LaneState::kWaiting && lane.kind == Collective::kSyncThreads) {
        waiting = &lane;
        break;
      }
    }
    if (waiting == nullptr) return false;
    for (const Lane& lane : lanes_) {
      if (lane.state == LaneState::kDone) {
        failAt(*waiting, "waits at " + describeWait(*waiting) + " for " + describeLane(lane) +
                             ", which exited");
      }
      if (lane.state != LaneState::kWaiting || lane.kind != Collective::kSyncThreads) return false;
    }
    for (Lane& lane : lanes_) lane.state = LaneState::kReady;
    return true;
  }

  // All lanes of `mask` in the warp starting at `first` wait at the same kind.
  void completeWarpCollective(std::size_t first, unsigned mask) {
    unsigned votes = 0;
    for (unsigned i = 0; i < 32; ++i) {
      if ((mask >> i & 1u) != 0 && lanes_[first + i].value != 0) votes |= 1u << i;
    }
    for (unsigned i = 0; i < 32; ++i) {
      if ((mask >> i & 1u) == 0) continue;
      Lane& lane = lanes_[first + i];
      switch (lane.kind) {
        case Collective::kBallot:
          lane.result = votes;
          break;
        case Collective::kAny:
          lane.result = votes != 0;
          break;
        case Collective::kAll:
          lane.result = votes == mask;
          break;
        case Collective::kSyncWarp:
        case Collective::kSyncThreads:
          break;
        default:
          lane.result = lanes_[first + shuffleSource(lane, i, mask)].value;
          break;
      }
      lane.state = LaneState::kReady;
    }
  }

  // The lane a shuffle reads, with CUDA's rules for width and out-of-range lanes.
  unsigned shuffleSource(const Lane& lane, unsigned i, unsigned mask) const {
    const int width = lane.width;
    if (width < 1 || width > 32 || (width & (width - 1)) != 0) {
      failAt(lane, "calls " + describeWait(lane) + " with width " + std::to_string(width) +
                       ", not a power of two up to 32");
    }
    const int self = static_cast<int>(i);
    const int base = self & ~(width - 1);
    int source = self;
    switch (lane.kind) {
      case Collective::kShfl:
        source = base + (lane.operand & (width - 1));
        break;
      case Collective::kShflUp:
        source = self - lane.operand < base ? self : self - lane.operand;
        break;
      case Collective::kShflDown:
        source = self + lane.operand >= base + width ? self : self + lane.operand;
        break;
      default:
        source = (self ^ lane.operand) >= base + width ? self : (self ^ lane.operand);
        break;
    }
    if ((mask >> source & 1u) == 0) {
      failAt(lane, "calls " + describeWait(lane) + " reading lane " + std::to_string(source) +
                       ", which is not in the mask");
    }
    return static_cast<unsigned>(source);
  }

  // Nothing can be released and some lanes wait: name one and what blocks it.
  [[noreturn]] void reportDeadlock() const {
    for (const Lane& lane : lanes_) {
      if (lane.state != LaneState::kWaiting) continue;
      const std::size_t first = lane.rank / 32 * 32;
      for (std::size_t j = 0; j < lanes_.size(); ++j) {
        const Lane& other = lanes_[j];
        const bool named = lane.kind == Collective::kSyncThreads
                               ? true
                               : j >= first && j < first + 32 && (lane.mask >> (j - first) & 1u);
        if (!named || other.state != LaneState::kWaiting) continue;
        if (other.kind != lane.kind || other.mask != lane.mask) {
          failAt(lane, "waits at " + describeWait(lane) + " while " + describeLane(other) +
                           " waits at " + describeWait(other) + ": the threads diverged");
        }
      }
    }
    fail("kernel " + std::string(launch_.kernel_name) + ": no thread can make progress");
  }

  const KernelLaunch& launch_;
  std::vector<Lane> lanes_;
  uint3 block_idx_{};
  Lane* current_ = nullptr;
  fctx::fcontext_t scheduler_ = nullptr;
  const void* scheduler_bottom_ = nullptr;
  std::size_t scheduler_size_ = 0;
};

thread_local BlockRunner* BlockRunner::t_runner = nullptr;

}  // namespace

std::uint64_t collective(Collective kind, unsigned mask, std::uint64_t value, int operand,
                         int width, const std::source_location& site) {
  return BlockRunner::wait(kind, mask, value, operand, width, site);
}

const ThreadCoordinates& coordinates() {
  if (t_coordinates == nullptr) {
    fail("threadIdx, blockIdx, blockDim or gridDim read outside a kernel thread");
  }
  return *t_coordinates;
}

std::string where(const std::source_location& site) {
  return std::string(site.file_name()) + ":" + std::to_string(site.line());
}

void fail(const std::string& message) {
  std::fprintf(stderr, "CUDA emulation: %s\n", message.c_str());
  std::fflush(stderr);
  std::abort();
}

int workerThreadCount() {
  static const int count = [] {
    if (const char* text = std::getenv("OVERLAP_CUDA_EMULATION_THREADS")) {
      int requested = 0;
      const char* end = text + std::strlen(text);
      const auto [stop, error] = std::from_chars(text, end, requested);
      if (error == std::errc() && stop == end && requested >= 1 && requested <= 256) {
        return requested;
      }
      fail(std::string("OVERLAP_CUDA_EMULATION_THREADS=") + text + " is not a count of 1 to 256");
    }
    return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  }();
  return count;
}

namespace {

std::uint64_t blocksOf(const KernelLaunch& launch) {
  return static_cast<std::uint64_t>(launch.grid.x) * launch.grid.y * launch.grid.z;
}

// The OS threads that run a grid's blocks, the caller's included.
std::size_t runnersOf(const KernelLaunch& launch) {
  return static_cast<std::size_t>(
      std::min<std::uint64_t>(blocksOf(launch), static_cast<std::uint64_t>(workerThreadCount())));
}

std::size_t lanesOf(const KernelLaunch& launch) {
  return static_cast<std::size_t>(launch.block.x) * launch.block.y * launch.block.z;
}

}  // namespace

bool reserveStacks(const KernelLaunch& launch) {
  const std::size_t lanes = lanesOf(launch);
  return stackPool().reserve(lanes * runnersOf(launch), lanes);
}

void runGrid(const KernelLaunch& launch) {
  const std::uint64_t blocks = blocksOf(launch);
  std::atomic<std::uint64_t> next{0};
  // The emulation's own memory running out: a helper with no runner runs no
  // block (the others run them all); a block cut short fails the grid, its
  // error raised on the caller's thread once every thread has ended.
  std::mutex failure_mutex;
  std::exception_ptr failure;
  const auto runBlocks = [&](BlockRunner& runner) {
    BlockRunner::t_runner = &runner;
    try {
      for (std::uint64_t block = next++; block < blocks; block = next++) runner.run(block);
    } catch (...) {
      next = blocks;
      const std::lock_guard lock(failure_mutex);
      if (!failure) failure = std::current_exception();
    }
    BlockRunner::t_runner = nullptr;
  };
  const auto help = [&] {
    std::optional<BlockRunner> runner;
    try {
      runner.emplace(launch);
    } catch (const std::bad_alloc&) {
      return;
    }
    runBlocks(*runner);
  };
  // As many runners as the pool holds stacks for (reserveStacks saw to one).
  const std::size_t runners =
      std::max<std::size_t>(1, std::min(runnersOf(launch), stackPool().held() / lanesOf(launch)));
  std::vector<std::jthread> threads;
  try {
    threads.reserve(runners - 1);
    for (std::size_t i = 1; i < runners; ++i) threads.emplace_back(help);
  } catch (const std::exception&) {
    // No OS thread to be had (the address space is full): the blocks run on
    // the threads made, the caller's at least, to the same result.
  }
  {
    BlockRunner runner(launch);  // throws, the helpers then joined, if it cannot be made
    runBlocks(runner);
  }
  threads.clear();  // joined
  if (failure) std::rethrow_exception(failure);
}

}  // namespace overlap::cuda_emulation::detail
