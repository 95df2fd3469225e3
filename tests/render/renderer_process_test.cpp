// OSMesa in a process of its own (render/renderer_process.h): the same
// pixels as in the program, the same errors, and running out of memory in
// the child is a std::bad_alloc in the program, never its death.
#include "render/renderer_process.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <future>
#include <new>
#include <stdexcept>
#include <thread>
#include <vector>

#include "render_test_support.h"

namespace overlap::render {
namespace {

// The child is forked before this process makes an OSMesa context (the
// header's rule): forked after `here` was made, it hung.
TEST(RendererProcess, DrawsTheSamePixelsAsTheRendererInTheProgram) {
  const std::vector<BoxInstance> boxes = test_support::randomBoxes(40, 10.0f, 7);
  const SceneView view{10.0f, boxes};
  RendererProcess apart(120, 90, ColourMode::kContact);
  OffscreenRenderer here(120, 90, ColourMode::kContact);
  const Image expected = here.render(view);
  for (int twice = 0; twice < 2; ++twice) {
    const Image image = apart.render(view);
    EXPECT_EQ(image.width, 120);
    EXPECT_EQ(image.height, 90);
    EXPECT_EQ(image.rgba, expected.rgba);
  }
}

TEST(RendererProcess, RaisesTheRenderersErrorsInTheProgram) {
  EXPECT_THROW(RendererProcess(0, 10), ImageSizeError);
  EXPECT_THROW(RendererProcess(1 << 20, 10), ImageSizeError);
  RendererProcess renderer(32, 32);
  std::vector<BoxInstance> boxes = test_support::randomBoxes(3, 10.0f, 1);
  boxes[1].edge = -1.0f;
  try {
    renderer.render(SceneView{10.0f, boxes});
    ADD_FAILURE() << "a box of edge -1 was drawn";
  } catch (const RenderError& error) {
    EXPECT_NE(std::string(error.what()).find("box 1"), std::string::npos) << error.what();
  }
}

#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)  // they map terabytes
// In a child of the test, so the limit stays there: under a small address
// space OSMesa fails or dies in the renderer's process, and the program
// gets a std::bad_alloc saying so (exit 3 below), never a signal.
TEST(RendererProcess, ItsProcessRunningOutOfMemoryIsABadAllocInTheProgram) {
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    rlimit in_use{};
    ::getrlimit(RLIMIT_AS, &in_use);
    std::FILE* statm = std::fopen("/proc/self/statm", "r");
    unsigned long long pages = 0;
    if (statm == nullptr || std::fscanf(statm, "%llu", &pages) != 1) ::_exit(10);
    std::fclose(statm);
    // A few MB beyond what is mapped: too little for llvmpipe's start-up.
    const rlimit tight{
        pages * static_cast<unsigned long long>(::sysconf(_SC_PAGE_SIZE)) + (8ULL << 20),
        in_use.rlim_max};
    if (::setrlimit(RLIMIT_AS, &tight) != 0) ::_exit(11);
    try {
      RendererProcess renderer(800, 600);
      renderer.render(SceneView{10.0f, test_support::randomBoxes(100, 10.0f, 3)});
      ::_exit(0);
    } catch (const std::bad_alloc&) {
      ::_exit(3);
    } catch (...) {
      ::_exit(4);
    }
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 3);
}
#endif

// Its child is a fork without exec: made while another thread runs (which
// may hold a lock the child would wait on forever), it refuses.
TEST(RendererProcess, RefusesToForkWhileAnotherThreadRuns) {
  std::promise<void> release;
  std::thread other([ended = release.get_future()] { ended.wait(); });
  EXPECT_THROW(RendererProcess(8, 8), std::logic_error);
  release.set_value();
  other.join();
  EXPECT_NO_THROW(RendererProcess(8, 8));
}

}  // namespace
}  // namespace overlap::render
