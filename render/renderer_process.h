// An OffscreenRenderer in a process of its own, so that OSMesa cannot take
// the program down.
//
// OSMesa writes through the null that a failed allocation returns (in
// OSMesaCreateContextAttribs, in its shader linking, in a draw), and a
// program that runs out of memory there dies by SIGSEGV or SIGABRT,
// leaving its temporaries behind.  A RendererProcess forks a child that
// owns the GL context and does every OSMesa call; it draws what it is sent
// through a pipe and sends the image back.  The child ignores the signals
// the program handles (gpu/base/interrupt.h: the program stops, and the
// child ends with it), holds no descriptor of the program's but its two
// pipes (its standard streams are /dev/null: its failures reach the program
// through the pipe, never as a second message on stderr), and ends when the
// program closes them or dies.
//
// Invariants: the same errors as OffscreenRenderer's (ImageSizeError,
// RenderError naming the problem), raised in the program; a child that
// dies throws RendererOutOfMemory, and every later call throws it too; a
// stop signal (gpu/base/interrupt.h) while the program waits for the
// child's start (OSMesa and LLVM opened) ends the wait at once: the child
// is killed and Interrupted names the start; the destructor waits for the child, so none outlives
// its RendererProcess. Rule: make it before the process starts a thread or calls OSMesa: the child
// is a fork without exec, which may use only what no other thread held at the fork (one forked
// after the process made an OSMesa context hung, tests/render/renderer_process_test.cpp); made with
// a second thread running it throws std::logic_error.  `overlap run` and `capture` make it before
// their task system's first thread.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <string>

#include "render/renderer.h"

namespace overlap::render {

class RendererProcess {
 public:
  // Starts the child and has it make the renderer (OffscreenRenderer's
  // constructor, and its errors).  Throws std::bad_alloc if no process can
  // be started.
  RendererProcess(int width, int height, ColourMode mode = ColourMode::kSizeClass);
  ~RendererProcess();
  RendererProcess(const RendererProcess&) = delete;
  RendererProcess& operator=(const RendererProcess&) = delete;

  // OffscreenRenderer::render(), done in the child.
  Image render(const SceneView& view);

  int width() const { return width_; }
  int height() const { return height_; }

 private:
  void send(const void* bytes, std::size_t size);
  // `waiting`: what a stop signal that ends the wait names (Interrupted);
  // null: the wait is not ended by one (a frame's render, which is short).
  void receive(void* bytes, std::size_t size, const char* waiting = nullptr);
  void receiveReply(const char* waiting = nullptr);
  // Kills and reaps the child, at once (a stop signal came).
  void stopChild();
  [[noreturn]] void childDied();

  int width_;
  int height_;
  pid_t child_ = -1;
  int to_child_ = -1;  // a socket to the child, both ways
  std::string why_;    // how the child ended, once it has
};

}  // namespace overlap::render
