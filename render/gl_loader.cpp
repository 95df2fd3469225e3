#include "render/gl_loader.h"

#include <string>

#include "render/osmesa_library.h"
#include "render/render_error.h"

namespace overlap::render {
namespace {

template <typename Function>
void load(Function& slot, const char* name) {
  const OSMESAproc address = osMesa().GetProcAddress(name);
  if (address == nullptr) {
    throw RenderError(std::string("OSMesa does not provide the OpenGL function ") + name);
  }
  slot = reinterpret_cast<Function>(address);
}

const char* glErrorName(GLenum error) {
  switch (error) {
    case GL_INVALID_ENUM:
      return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE:
      return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION:
      return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION:
      return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY:
      return "GL_OUT_OF_MEMORY";
    default:
      return "an unknown GL error code";
  }
}

}  // namespace

GlFunctions loadGlFunctions() {
  GlFunctions gl{};
  // Spelling each name once keeps the member and the looked-up symbol in step.
#define OVERLAP_LOAD_GL(name) load(gl.name, "gl" #name)
  OVERLAP_LOAD_GL(Clear);
  OVERLAP_LOAD_GL(ClearColor);
  OVERLAP_LOAD_GL(CullFace);
  OVERLAP_LOAD_GL(DrawArrays);
  OVERLAP_LOAD_GL(Enable);
  OVERLAP_LOAD_GL(GetError);
  OVERLAP_LOAD_GL(GetIntegerv);
  OVERLAP_LOAD_GL(PixelStorei);
  OVERLAP_LOAD_GL(ReadPixels);
  OVERLAP_LOAD_GL(Viewport);
  OVERLAP_LOAD_GL(AttachShader);
  OVERLAP_LOAD_GL(CompileShader);
  OVERLAP_LOAD_GL(CreateProgram);
  OVERLAP_LOAD_GL(CreateShader);
  OVERLAP_LOAD_GL(DeleteShader);
  OVERLAP_LOAD_GL(GetProgramInfoLog);
  OVERLAP_LOAD_GL(GetProgramiv);
  OVERLAP_LOAD_GL(GetShaderInfoLog);
  OVERLAP_LOAD_GL(GetShaderiv);
  OVERLAP_LOAD_GL(GetUniformLocation);
  OVERLAP_LOAD_GL(LinkProgram);
  OVERLAP_LOAD_GL(ShaderSource);
  OVERLAP_LOAD_GL(UniformMatrix4fv);
  OVERLAP_LOAD_GL(UseProgram);
  OVERLAP_LOAD_GL(BindBuffer);
  OVERLAP_LOAD_GL(BindVertexArray);
  OVERLAP_LOAD_GL(BufferData);
  OVERLAP_LOAD_GL(DrawArraysInstanced);
  OVERLAP_LOAD_GL(EnableVertexAttribArray);
  OVERLAP_LOAD_GL(GenBuffers);
  OVERLAP_LOAD_GL(GenVertexArrays);
  OVERLAP_LOAD_GL(VertexAttribDivisor);
  OVERLAP_LOAD_GL(VertexAttribPointer);
  OVERLAP_LOAD_GL(BindFramebuffer);
  OVERLAP_LOAD_GL(BindRenderbuffer);
  OVERLAP_LOAD_GL(CheckFramebufferStatus);
  OVERLAP_LOAD_GL(FramebufferRenderbuffer);
  OVERLAP_LOAD_GL(GenFramebuffers);
  OVERLAP_LOAD_GL(GenRenderbuffers);
  OVERLAP_LOAD_GL(RenderbufferStorage);
#undef OVERLAP_LOAD_GL
  return gl;
}

void throwIfGlError(const GlFunctions& gl, std::string_view stage) {
  const GLenum first = gl.GetError();
  if (first == GL_NO_ERROR) return;
  while (gl.GetError() != GL_NO_ERROR) {
  }
  throw RenderError(std::string(stage) + ": OpenGL error " + glErrorName(first));
}

}  // namespace overlap::render
