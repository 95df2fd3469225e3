#include "gpu/task_system.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>
#include <oneapi/tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace overlap {
namespace {

std::pair<std::size_t, std::size_t> pieceBounds(std::size_t piece, std::size_t count,
                                                std::size_t grain) {
  return {piece * grain, std::min(count, (piece + 1) * grain)};
}

// Every piece on the calling thread, in order: one thread, or one piece.
void runPiecesHere(std::size_t count, std::size_t grain, const TaskSystem::PieceBody& body) {
  for (std::size_t piece = 0, pieces = pieceCount(count, grain); piece < pieces; ++piece) {
    const auto [first, end] = pieceBounds(piece, count, grain);
    body(first, end);
  }
}

// ---- oneTBB: one arena of `threads` slots, the first kept for the caller ----

class OneTbbGroup final : public TaskGroup {
 public:
  explicit OneTbbGroup(tbb::task_arena& arena) : arena_(arena) {}
  // noexcept: tbb::task_group's own destructor may throw, but only when not
  // waited for, and this one waits.
  ~OneTbbGroup() noexcept override {
    try {
      wait();
    } catch (...) {  // the owner that wanted the error called wait() itself
    }
  }
  void run(std::function<void()> job) override {
    arena_.execute([&] { group_.run(std::move(job)); });
  }
  void wait() override {
    arena_.execute([&] { group_.wait(); });
  }

 private:
  tbb::task_arena& arena_;
  tbb::task_group group_;
};

class OneTbbTaskSystem final : public TaskSystem {
 public:
  // The arena is made here, not at its first use: oneTBB's lazy initialisation
  // cannot fail, and when it does (out of memory) every later use of the arena
  // spins forever on the half-made one, a group's destructor among them.
  explicit OneTbbTaskSystem(int threads) : threads_(threads), arena_(threads, 1) {
    arena_.initialize();
  }

  int threads() const override { return threads_; }
  int threadIndex() const override {
    return std::max(0, tbb::this_task_arena::current_thread_index());
  }
  void forEachPiece(std::size_t count, std::size_t grain, const PieceBody& body) override {
    const std::size_t pieces = pieceCount(count, grain);
    if (threads_ == 1 || pieces <= 1) {
      runPiecesHere(count, grain, body);
      return;
    }
    arena_.execute([&] {
      tbb::this_task_arena::isolate([&] {
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, pieces, 1),
            [&](const tbb::blocked_range<std::size_t>& range) {
              for (std::size_t piece = range.begin(); piece != range.end(); ++piece) {
                const auto [first, end] = pieceBounds(piece, count, grain);
                body(first, end);
              }
            },
            tbb::simple_partitioner{});
      });
    });
  }
  std::unique_ptr<TaskGroup> makeGroup() override { return std::make_unique<OneTbbGroup>(arena_); }

 private:
  int threads_;
  tbb::task_arena arena_;
};

// ---- Plain threads: threads - 1 workers and one queue ----

class PlainThreadSystem;
thread_local const PlainThreadSystem* tl_system = nullptr;
thread_local int tl_index = 0;

class PlainThreadSystem final : public TaskSystem {
 public:
  explicit PlainThreadSystem(int threads) : threads_(threads) {
    workers_.reserve(static_cast<std::size_t>(threads - 1));
    for (int index = 1; index < threads; ++index) {
      workers_.emplace_back([this, index] { work(index); });
    }
  }
  ~PlainThreadSystem() override {
    {
      const std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    changed_.notify_all();
    for (std::thread& worker : workers_) worker.join();
  }

  int threads() const override { return threads_; }
  int threadIndex() const override { return tl_system == this ? tl_index : 0; }

  void forEachPiece(std::size_t count, std::size_t grain, const PieceBody& body) override {
    const std::size_t pieces = pieceCount(count, grain);
    if (threads_ == 1 || pieces <= 1) {
      runPiecesHere(count, grain, body);
      return;
    }
    // Helpers may run after the loop has returned; they then find no piece
    // left and never touch `body`.
    auto loop = std::make_shared<Loop>(count, grain, pieces, &body);
    const std::size_t helpers = std::min<std::size_t>(workers_.size(), pieces - 1);
    for (std::size_t helper = 0; helper < helpers; ++helper) push([loop] { loop->work(); });
    loop->work();
    std::unique_lock lock(loop->mutex);
    loop->ended.wait(lock, [&] { return loop->finished == pieces; });
    if (loop->error) std::rethrow_exception(loop->error);
  }

  std::unique_ptr<TaskGroup> makeGroup() override;

  void push(std::function<void()> job) {
    {
      const std::lock_guard lock(mutex_);
      jobs_.push_back(std::move(job));
    }
    changed_.notify_all();
  }

  // Runs queued jobs on the calling thread until done() holds.
  template <typename Done>
  void helpUntil(const Done& done) {
    std::unique_lock lock(mutex_);
    while (!done()) {
      if (jobs_.empty()) {
        changed_.wait(lock);
        continue;
      }
      std::function<void()> job = std::move(jobs_.front());
      jobs_.pop_front();
      lock.unlock();
      job();
      lock.lock();
    }
  }

  void notifyChanged() {
    { const std::lock_guard lock(mutex_); }
    changed_.notify_all();
  }

 private:
  struct Loop {
    Loop(std::size_t count_in, std::size_t grain_in, std::size_t pieces_in,
         const PieceBody* body_in)
        : count(count_in), grain(grain_in), pieces(pieces_in), body(body_in) {}

    void work() {
      for (std::size_t piece = next.fetch_add(1); piece < pieces; piece = next.fetch_add(1)) {
        if (!failed.load()) {
          try {
            const auto [first, end] = pieceBounds(piece, count, grain);
            (*body)(first, end);
          } catch (...) {
            const std::lock_guard lock(mutex);
            if (!error) error = std::current_exception();
            failed.store(true);
          }
        }
        const std::lock_guard lock(mutex);
        if (++finished == pieces) ended.notify_all();
      }
    }

    const std::size_t count, grain, pieces;
    const PieceBody* body;
    std::atomic<std::size_t> next{0};
    std::atomic<bool> failed{false};
    std::mutex mutex;
    std::condition_variable ended;
    std::size_t finished = 0;  // guarded by mutex
    std::exception_ptr error;  // guarded by mutex
  };

  // A worker runs queued jobs until the system stops and the queue is empty.
  void work(int index) {
    tl_system = this;
    tl_index = index;
    helpUntil([this] { return stopping_ && jobs_.empty(); });  // under mutex_
  }

  int threads_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> jobs_;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

class PlainThreadGroup final : public TaskGroup {
 public:
  explicit PlainThreadGroup(PlainThreadSystem& system) : system_(system) {}
  ~PlainThreadGroup() override {
    try {
      wait();
    } catch (...) {  // the owner that wanted the error called wait() itself
    }
  }
  void run(std::function<void()> job) override {
    pending_.fetch_add(1);
    // After its fetch_sub the group may be gone: only `system` is touched then.
    system_.push([this, &system = system_, job = std::move(job)] {
      try {
        job();
      } catch (...) {
        const std::lock_guard lock(mutex_);
        if (!error_) error_ = std::current_exception();
      }
      pending_.fetch_sub(1);
      system.notifyChanged();
    });
  }
  // Helps with the queue while it waits: with one thread nobody else would.
  void wait() override {
    system_.helpUntil([this] { return pending_.load() == 0; });
    std::exception_ptr error;
    {
      const std::lock_guard lock(mutex_);
      std::swap(error, error_);
    }
    if (error) std::rethrow_exception(error);
  }

 private:
  PlainThreadSystem& system_;
  std::atomic<int> pending_{0};
  std::mutex mutex_;
  std::exception_ptr error_;
};

std::unique_ptr<TaskGroup> PlainThreadSystem::makeGroup() {
  return std::make_unique<PlainThreadGroup>(*this);
}

}  // namespace

TaskBackEnd defaultTaskBackEnd() {
#ifdef OVERLAP_PLAIN_THREAD_TASKS
  return TaskBackEnd::kPlainThreads;
#else
  return TaskBackEnd::kOneTbb;
#endif
}

std::unique_ptr<TaskSystem> makeTaskSystem(int threads, TaskBackEnd back_end) {
  if (threads < 0) {
    throw std::invalid_argument("task system: thread count " + std::to_string(threads) +
                                " is negative (0 means every hardware thread)");
  }
  if (threads == 0) threads = std::max(1, tbb::info::default_concurrency());
  if (back_end == TaskBackEnd::kPlainThreads) return std::make_unique<PlainThreadSystem>(threads);
  return std::make_unique<OneTbbTaskSystem>(threads);
}

TaskSystem& defaultTaskSystem() {
  static const std::unique_ptr<TaskSystem> system = makeTaskSystem();
  return *system;
}

std::size_t grainFor(std::size_t count, int threads, std::size_t pieces_per_thread,
                     std::size_t min_grain) {
  const std::size_t target = std::max<std::size_t>(1, static_cast<std::size_t>(threads)) *
                             std::max<std::size_t>(1, pieces_per_thread);
  return std::max({std::size_t{1}, min_grain, (count + target - 1) / target});
}

}  // namespace overlap
