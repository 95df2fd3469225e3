#include "render/shaders.h"

#include <string>
#include <string_view>

#include "render/render_error.h"

namespace overlap::render {
namespace {

constexpr const char* kBoxVertexShader = R"glsl(
#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in mat4 model;
layout(location = 6) in vec3 colour;
uniform mat4 view_projection;
out vec3 world_normal;
out vec3 base_colour;
void main() {
  world_normal = mat3(model) * normal;
  base_colour = colour;
  gl_Position = view_projection * model * vec4(position, 1.0);
}
)glsl";

// The light comes from above and to the side of the camera, so that the three
// faces a box shows the camera get three different shades.
constexpr const char* kBoxFragmentShader = R"glsl(
#version 330 core
in vec3 world_normal;
in vec3 base_colour;
out vec4 fragment_colour;
const vec3 kTowardsLight = normalize(vec3(0.3, 1.0, 0.5));
const float kAmbient = 0.3;
const float kDiffuse = 0.7;
void main() {
  float lambert = max(dot(normalize(world_normal), kTowardsLight), 0.0);
  fragment_colour = vec4(base_colour * (kAmbient + kDiffuse * lambert), 1.0);
}
)glsl";

constexpr const char* kEdgeVertexShader = R"glsl(
#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 transform;
void main() {
  gl_Position = transform * vec4(position, 1.0);
}
)glsl";

constexpr const char* kEdgeFragmentShader = R"glsl(
#version 330 core
out vec4 fragment_colour;
void main() {
  fragment_colour = vec4(0.2, 0.2, 0.24, 1.0);
}
)glsl";

// A shader's or a program's info log, read with that kind's two getters
// (GetShaderiv and GetShaderInfoLog, or GetProgramiv and GetProgramInfoLog).
std::string infoLog(GLuint object, PFNGLGETSHADERIVPROC get_parameter,
                    PFNGLGETSHADERINFOLOGPROC get_log) {
  GLint length = 0;
  get_parameter(object, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<std::size_t>(length > 0 ? length : 0), '\0');
  if (length > 0) get_log(object, length, nullptr, log.data());
  return log;
}

GLuint compileShader(const GlFunctions& gl, GLenum stage, const char* source,
                     std::string_view name) {
  const GLuint shader = gl.CreateShader(stage);
  if (shader == 0) throw RenderError(std::string("cannot create the shader ") + std::string(name));
  gl.ShaderSource(shader, 1, &source, nullptr);
  gl.CompileShader(shader);
  GLint compiled = GL_FALSE;
  gl.GetShaderiv(shader, GL_COMPILE_STATUS, &compiled);
  if (compiled != GL_TRUE) {
    const std::string log = infoLog(shader, gl.GetShaderiv, gl.GetShaderInfoLog);
    gl.DeleteShader(shader);
    throw RenderError("shader " + std::string(name) + " does not compile: " + log);
  }
  return shader;
}

GLuint linkProgram(const GlFunctions& gl, const char* vertex_source, const char* fragment_source,
                   std::string_view name) {
  const std::string prefix(name);
  const GLuint vertex = compileShader(gl, GL_VERTEX_SHADER, vertex_source, prefix + ".vert");
  GLuint fragment = 0;
  try {
    fragment = compileShader(gl, GL_FRAGMENT_SHADER, fragment_source, prefix + ".frag");
  } catch (...) {
    gl.DeleteShader(vertex);
    throw;
  }
  const GLuint program = gl.CreateProgram();
  gl.AttachShader(program, vertex);
  gl.AttachShader(program, fragment);
  gl.LinkProgram(program);
  // The program keeps what it needs; the shader objects can go.
  gl.DeleteShader(vertex);
  gl.DeleteShader(fragment);
  GLint linked = GL_FALSE;
  gl.GetProgramiv(program, GL_LINK_STATUS, &linked);
  if (linked != GL_TRUE) {
    throw RenderError("program " + prefix +
                      " does not link: " + infoLog(program, gl.GetProgramiv, gl.GetProgramInfoLog));
  }
  throwIfGlError(gl, "building the program " + prefix);
  return program;
}

}  // namespace

GLuint buildBoxProgram(const GlFunctions& gl) {
  return linkProgram(gl, kBoxVertexShader, kBoxFragmentShader, "box");
}

GLuint buildEdgeProgram(const GlFunctions& gl) {
  return linkProgram(gl, kEdgeVertexShader, kEdgeFragmentShader, "edge");
}

GLint requireUniform(const GlFunctions& gl, GLuint program, const char* name) {
  const GLint location = gl.GetUniformLocation(program, name);
  if (location < 0) throw RenderError(std::string("shader program has no uniform ") + name);
  return location;
}

}  // namespace overlap::render
