#include "render/renderer_process.h"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "gpu/base/interrupt.h"

namespace overlap::render {
namespace {

// A box as it crosses the socket.
struct WireBox {
  float centre[3];
  float orientation[4];  // x, y, z, w
  float edge;
  std::int32_t size_class;
  std::int32_t in_contact;
};

WireBox toWire(const BoxInstance& box) {
  return {{box.centre.x(), box.centre.y(), box.centre.z()},
          {box.orientation.x(), box.orientation.y(), box.orientation.z(), box.orientation.w()},
          box.edge,
          box.size_class,
          box.in_contact ? 1 : 0};
}

BoxInstance fromWire(const WireBox& box) {
  return {Eigen::Vector3f(box.centre[0], box.centre[1], box.centre[2]),
          Eigen::Quaternionf(box.orientation[3], box.orientation[0], box.orientation[1],
                             box.orientation[2]),
          box.edge, box.size_class, box.in_contact != 0};
}

// A reply's first byte.
enum class Reply : std::uint8_t { kDone, kRenderError, kImageSizeError, kOutOfMemory };

// Every byte of `size` written, or false.
bool writeAll(int fd, const void* bytes, std::size_t size) {
  const auto* next = static_cast<const char*>(bytes);
  while (size > 0) {
    const ssize_t written = ::send(fd, next, size, MSG_NOSIGNAL);
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) return false;
    next += written;
    size -= static_cast<std::size_t>(written);
  }
  return true;
}

// Every byte of `size` read, or false (the other end closed or failed).
bool readAll(int fd, void* bytes, std::size_t size) {
  auto* next = static_cast<char*>(bytes);
  while (size > 0) {
    const ssize_t got = ::recv(fd, next, size, 0);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) return false;
    next += got;
    size -= static_cast<std::size_t>(got);
  }
  return true;
}

void replyError(int fd, Reply kind, const std::string& message) {
  const auto length = static_cast<std::uint32_t>(message.size());
  if (!writeAll(fd, &kind, 1) || !writeAll(fd, &length, sizeof(length)) ||
      !writeAll(fd, message.data(), message.size())) {
    ::_exit(1);
  }
}

// Runs `work`, replying with its error if it throws; true if it did not.
template <class Work>
bool replying(int fd, Work&& work) {
  try {
    work();
    return true;
  } catch (const ImageSizeError& error) {
    replyError(fd, Reply::kImageSizeError, error.what());
  } catch (const RendererOutOfMemory& error) {
    replyError(fd, Reply::kOutOfMemory, error.what());
  } catch (const std::bad_alloc&) {
    replyError(fd, Reply::kOutOfMemory, "an allocation in OSMesa's renderer failed");
  } catch (const std::exception& error) {
    replyError(fd, Reply::kRenderError, error.what());
  }
  return false;
}

// The child: makes the renderer, then renders each scene it is sent until
// the program closes its end.  Never returns, and runs none of the
// program's destructors or exit handlers (its outputs are the program's).
[[noreturn]] void serve(int fd, pid_t program, int width, int height, ColourMode mode) {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() != program) ::_exit(0);
  for (const int signal_number : {SIGINT, SIGTERM, SIGHUP}) std::signal(signal_number, SIG_IGN);
  // No descriptor of the program's stays open here (a FIFO's reader waits
  // for its last writer, a temporary for its last holder).
  if (fd > 3) ::close_range(3, static_cast<unsigned>(fd) - 1, 0);
  ::close_range(static_cast<unsigned>(fd) + 1, ~0U, 0);
  // Nor its standard streams: what fails here reaches the program through
  // `fd` and is said there in one line; an abort's own text (glibc's,
  // LLVM's, under a tight ulimit -v) would be a second, alarming one.
  if (const int null = ::open("/dev/null", O_RDWR | O_CLOEXEC); null >= 0) {
    for (const int standard : {STDIN_FILENO, STDOUT_FILENO, STDERR_FILENO}) ::dup2(null, standard);
    if (null > STDERR_FILENO) ::close(null);
  }
  std::unique_ptr<OffscreenRenderer> renderer;
  if (!replying(fd, [&] { renderer = std::make_unique<OffscreenRenderer>(width, height, mode); })) {
    ::_exit(0);
  }
  const Reply done = Reply::kDone;
  if (!writeAll(fd, &done, 1)) ::_exit(0);
  std::vector<WireBox> wire;
  std::vector<BoxInstance> boxes;
  for (;;) {
    std::uint64_t count = 0;
    float half_extent = 0;
    if (!readAll(fd, &count, sizeof(count)) || !readAll(fd, &half_extent, sizeof(half_extent))) {
      ::_exit(0);
    }
    Image image;
    const bool rendered = replying(fd, [&] {
      wire.resize(count);
      if (!readAll(fd, wire.data(), count * sizeof(WireBox))) ::_exit(0);
      boxes.clear();
      for (const WireBox& box : wire) boxes.push_back(fromWire(box));
      image = renderer->render(SceneView{half_extent, boxes});
    });
    if (rendered &&
        (!writeAll(fd, &done, 1) || !writeAll(fd, image.rgba.data(), image.rgba.size()))) {
      ::_exit(0);
    }
  }
}

}  // namespace

namespace {

// The threads of this process, as the kernel lists them.
int threadsRunning() {
  int count = 0;
  std::error_code error;
  for (std::filesystem::directory_iterator entry("/proc/self/task", error), end;
       !error && entry != end; entry.increment(error)) {
    ++count;
  }
  return count;
}

}  // namespace

RendererProcess::RendererProcess(int width, int height, ColourMode mode)
    : width_(width), height_(height) {
  if (const int threads = threadsRunning(); threads > 1) {
    throw std::logic_error("RendererProcess: made with " + std::to_string(threads) +
                           " threads running; make it before the first (its child is a fork "
                           "without exec)");
  }
  int ends[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, ends) != 0) throw std::bad_alloc();
  const pid_t program = ::getpid();
  child_ = ::fork();
  if (child_ < 0) {
    ::close(ends[0]);
    ::close(ends[1]);
    throw std::bad_alloc();
  }
  if (child_ == 0) serve(ends[1], program, width, height, mode);
  ::close(ends[1]);
  to_child_ = ends[0];
  receiveReply("the start of OSMesa's renderer");
}

RendererProcess::~RendererProcess() {
  if (to_child_ >= 0) ::close(to_child_);
  if (child_ > 0) {
    while (::waitpid(child_, nullptr, 0) < 0 && errno == EINTR) {
    }
  }
}

void RendererProcess::send(const void* bytes, std::size_t size) {
  if (to_child_ < 0 || !writeAll(to_child_, bytes, size)) childDied();
}

void RendererProcess::receive(void* bytes, std::size_t size, const char* waiting) {
  auto* next = static_cast<char*>(bytes);
  while (to_child_ >= 0 && size > 0) {
    // A stop signal ends the start's wait, however long the child takes (it
    // opens OSMesa and LLVM, which may crawl under memory pressure); a
    // frame's is short, and the run stops at the frame's end as ever.
    if (const int signal_number = waiting != nullptr ? pendingInterrupt() : 0; signal_number != 0) {
      stopChild();
      throw Interrupted(signal_number, waiting);
    }
    const ssize_t got = ::recv(to_child_, next, size, 0);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) break;
    next += got;
    size -= static_cast<std::size_t>(got);
  }
  if (size > 0) childDied();
}

void RendererProcess::stopChild() {
  if (to_child_ >= 0) {
    ::close(to_child_);
    to_child_ = -1;
  }
  if (child_ > 0) {
    ::kill(child_, SIGKILL);
    while (::waitpid(child_, nullptr, 0) < 0 && errno == EINTR) {
    }
    child_ = -1;
  }
  why_ = "OSMesa's renderer process was stopped with the program";
}

// Reads a reply's first byte, and throws the error it brings.
void RendererProcess::receiveReply(const char* waiting) {
  Reply reply{};
  receive(&reply, 1, waiting);
  if (reply == Reply::kDone) return;
  std::uint32_t length = 0;
  receive(&length, sizeof(length), waiting);
  std::string message(length, '\0');
  receive(message.data(), length, waiting);
  switch (reply) {
    case Reply::kImageSizeError:
      throw ImageSizeError(message);
    case Reply::kOutOfMemory:
      throw RendererOutOfMemory(message);
    default:
      throw RenderError(message);
  }
}

void RendererProcess::childDied() {
  std::string how = "ended";
  if (to_child_ >= 0) {
    ::close(to_child_);
    to_child_ = -1;
    int status = 0;
    pid_t waited = -1;
    while ((waited = ::waitpid(child_, &status, 0)) < 0 && errno == EINTR) {
    }
    if (waited == child_) {
      child_ = -1;
      if (WIFSIGNALED(status)) {
        const char* name = ::sigabbrev_np(WTERMSIG(status));
        how = "ended by " + (name != nullptr ? "SIG" + std::string(name)
                                             : "signal " + std::to_string(WTERMSIG(status)));
      } else if (WIFEXITED(status)) {
        how = "exited with " + std::to_string(WEXITSTATUS(status));
      }
    }
    // Most likely memory (OSMesa writes through a failed allocation's null),
    // but a broken library or a kill from outside end it so too.
    why_ = "OSMesa's renderer process " + how +
           ", as OSMesa does when an allocation fails (or its library is broken, or the process "
           "was killed)";
  }
  throw RendererOutOfMemory(why_);
}

Image RendererProcess::render(const SceneView& view) {
  const std::uint64_t count = view.boxes.size();
  send(&count, sizeof(count));
  send(&view.interior_half_extent, sizeof(view.interior_half_extent));
  std::vector<WireBox> wire;
  wire.reserve(view.boxes.size());
  for (const BoxInstance& box : view.boxes) wire.push_back(toWire(box));
  send(wire.data(), wire.size() * sizeof(WireBox));
  receiveReply();
  Image image{width_, height_, {}};
  image.rgba.resize(4 * static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_));
  receive(image.rgba.data(), image.rgba.size());
  return image;
}

}  // namespace overlap::render
