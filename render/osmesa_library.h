// OSMesa's own entry points, from a libOSMesa opened at the first renderer
// (dlopen), not linked into the program.
//
// Linked, libOSMesa brings libLLVM, whose static constructors run before
// main(): under a `ulimit -v` just above what the program needs they abort
// ("LLVM ERROR: out of memory") or crash before any handler of ours is in
// place, in every subcommand, --version included.  Opened here, they run in
// the renderer's own process (render/renderer_process.h), which may die
// without taking the program down, and a program that renders nothing
// never maps them.
//
// Invariant: a library returned by osMesa() has every pointer set; a
// library or entry point that is missing is a RenderError naming it, and a
// library that cannot be mapped (no address space left) RendererOutOfMemory.
#pragma once

#undef GL_GLEXT_PROTOTYPES
#include <GL/osmesa.h>

namespace overlap::render {

struct OsMesaLibrary {
  decltype(&::OSMesaCreateContextAttribs) CreateContextAttribs;
  decltype(&::OSMesaDestroyContext) DestroyContext;
  decltype(&::OSMesaGetCurrentContext) GetCurrentContext;
  decltype(&::OSMesaGetProcAddress) GetProcAddress;
  decltype(&::OSMesaMakeCurrent) MakeCurrent;
};

// Opens libOSMesa at the first call (thread-safe); later calls return the
// same table.  A failed open is retried at the next call.
const OsMesaLibrary& osMesa();

}  // namespace overlap::render
