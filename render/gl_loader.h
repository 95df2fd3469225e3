// The OpenGL entry points the renderer uses, fetched from OSMesa.
//
// The renderer links libOSMesa alone: linking libGL as well makes the GL calls
// go to libglvnd's dispatch instead of OSMesa's context, and shaders then fail
// silently.  So no GL function is called by its symbol; each one is looked up
// once with OSMesaGetProcAddress into a GlFunctions table.
//
// Invariant: a GlFunctions returned by loadGlFunctions() has every pointer set
// (a missing one is a RenderError naming it).  The pointers are only valid to
// call while an OSMesa context is current on the calling thread.
#pragma once

// The GL headers declare the extension prototypes only when asked; the loader
// wants the PFN...PROC typedefs and never the prototypes.
#undef GL_GLEXT_PROTOTYPES
#include <GL/osmesa.h>
// osmesa.h brings in GL/gl.h, which brings in GL/glext.h.

#include <string_view>

namespace overlap::render {

// Members are named after the GL function without its gl prefix, so that
// gl.Clear(...) reads as glClear(...).
struct GlFunctions {
  // OpenGL 1.x: gl.h declares these without PFN typedefs.
  decltype(&::glClear) Clear;
  decltype(&::glClearColor) ClearColor;
  decltype(&::glCullFace) CullFace;
  decltype(&::glDrawArrays) DrawArrays;
  decltype(&::glEnable) Enable;
  decltype(&::glGetError) GetError;
  decltype(&::glGetIntegerv) GetIntegerv;
  decltype(&::glPixelStorei) PixelStorei;
  decltype(&::glReadPixels) ReadPixels;
  decltype(&::glViewport) Viewport;
  // Shaders and programs.
  PFNGLATTACHSHADERPROC AttachShader;
  PFNGLCOMPILESHADERPROC CompileShader;
  PFNGLCREATEPROGRAMPROC CreateProgram;
  PFNGLCREATESHADERPROC CreateShader;
  PFNGLDELETESHADERPROC DeleteShader;
  PFNGLGETPROGRAMINFOLOGPROC GetProgramInfoLog;
  PFNGLGETPROGRAMIVPROC GetProgramiv;
  PFNGLGETSHADERINFOLOGPROC GetShaderInfoLog;
  PFNGLGETSHADERIVPROC GetShaderiv;
  PFNGLGETUNIFORMLOCATIONPROC GetUniformLocation;
  PFNGLLINKPROGRAMPROC LinkProgram;
  PFNGLSHADERSOURCEPROC ShaderSource;
  PFNGLUNIFORMMATRIX4FVPROC UniformMatrix4fv;
  PFNGLUSEPROGRAMPROC UseProgram;
  // Buffers and vertex arrays.
  PFNGLBINDBUFFERPROC BindBuffer;
  PFNGLBINDVERTEXARRAYPROC BindVertexArray;
  PFNGLBUFFERDATAPROC BufferData;
  PFNGLDRAWARRAYSINSTANCEDPROC DrawArraysInstanced;
  PFNGLENABLEVERTEXATTRIBARRAYPROC EnableVertexAttribArray;
  PFNGLGENBUFFERSPROC GenBuffers;
  PFNGLGENVERTEXARRAYSPROC GenVertexArrays;
  PFNGLVERTEXATTRIBDIVISORPROC VertexAttribDivisor;
  PFNGLVERTEXATTRIBPOINTERPROC VertexAttribPointer;
  // The offscreen framebuffer.
  PFNGLBINDFRAMEBUFFERPROC BindFramebuffer;
  PFNGLBINDRENDERBUFFERPROC BindRenderbuffer;
  PFNGLCHECKFRAMEBUFFERSTATUSPROC CheckFramebufferStatus;
  PFNGLFRAMEBUFFERRENDERBUFFERPROC FramebufferRenderbuffer;
  PFNGLGENFRAMEBUFFERSPROC GenFramebuffers;
  PFNGLGENRENDERBUFFERSPROC GenRenderbuffers;
  PFNGLRENDERBUFFERSTORAGEPROC RenderbufferStorage;
};

// Looks every function up; throws RenderError naming the first one missing.
GlFunctions loadGlFunctions();

// Throws RenderError "<stage>: OpenGL error GL_..." if the GL error flag is
// set, after draining every pending error so the next check starts clean.
void throwIfGlError(const GlFunctions& gl, std::string_view stage);

}  // namespace overlap::render
