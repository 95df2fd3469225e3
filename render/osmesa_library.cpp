#include "render/osmesa_library.h"

#include <dlfcn.h>

#include <mutex>
#include <string>

#include "render/render_error.h"

namespace overlap::render {
namespace {

template <typename Function>
void findEntryPoint(void* library, Function& slot, const char* name) {
  void* const address = dlsym(library, name);
  if (address == nullptr) {
    throw RenderError(std::string(OVERLAP_OSMESA_LIBRARY " has no ") + name);
  }
  slot = reinterpret_cast<Function>(address);
}

OsMesaLibrary openOsMesa() {
  // Never closed: its code may run until the process ends.
  void* const library = dlopen(OVERLAP_OSMESA_LIBRARY, RTLD_NOW | RTLD_LOCAL);
  if (library == nullptr) {
    const char* const error = dlerror();
    const std::string why = error != nullptr ? error : OVERLAP_OSMESA_LIBRARY;
    // The loader maps the library's segments: without the address space for
    // them (ulimit -v) that is memory run out, not a missing library.
    if (why.find("map segment") != std::string::npos ||
        why.find("Cannot allocate memory") != std::string::npos) {
      throw RendererOutOfMemory("OSMesa could not be loaded: " + why);
    }
    throw RenderError("OSMesa could not be opened: " + why);
  }
  OsMesaLibrary table{};
  findEntryPoint(library, table.CreateContextAttribs, "OSMesaCreateContextAttribs");
  findEntryPoint(library, table.DestroyContext, "OSMesaDestroyContext");
  findEntryPoint(library, table.GetCurrentContext, "OSMesaGetCurrentContext");
  findEntryPoint(library, table.GetProcAddress, "OSMesaGetProcAddress");
  findEntryPoint(library, table.MakeCurrent, "OSMesaMakeCurrent");
  return table;
}

}  // namespace

const OsMesaLibrary& osMesa() {
  static std::mutex mutex;
  static OsMesaLibrary table{};
  static bool opened = false;
  const std::lock_guard lock(mutex);
  if (!opened) {
    table = openOsMesa();
    opened = true;
  }
  return table;
}

}  // namespace overlap::render
