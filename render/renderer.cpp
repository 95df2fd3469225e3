#include "render/renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>

#include "render/camera.h"
#include "render/gl_loader.h"
#include "render/osmesa_library.h"
#include "render/shaders.h"

namespace overlap::render {
namespace {

struct OsMesaContextDeleter {
  void operator()(osmesa_context* context) const {
    if (osMesa().GetCurrentContext() == context) osMesa().MakeCurrent(nullptr, nullptr, 0, 0, 0);
    osMesa().DestroyContext(context);
  }
};
using OsMesaContextHandle = std::unique_ptr<osmesa_context, OsMesaContextDeleter>;

struct MeshVertex {
  float position[3];
  float normal[3];
};

// What each box instance sends to the box program.
struct InstanceAttributes {
  float model[16];  // column-major, as GL reads a mat4 attribute
  float colour[3];
};

constexpr int kCubeVertexCount = 36;
constexpr int kEdgeVertexCount = 24;

// The unit cube [-0.5, 0.5]^3 as 12 triangles, counter-clockwise seen from
// outside so back faces can be culled, each face with its own normal.
std::array<MeshVertex, kCubeVertexCount> unitCubeTriangles() {
  std::array<MeshVertex, kCubeVertexCount> vertices{};
  int next = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3;
    const int v = (axis + 2) % 3;
    for (const float side : {-1.0f, 1.0f}) {
      // Walking the face's corners in (u, v) order is counter-clockwise seen
      // from +axis; the face on the -axis side walks them backwards.
      std::array<std::array<float, 2>, 4> corners = {
          {{-0.5f, -0.5f}, {0.5f, -0.5f}, {0.5f, 0.5f}, {-0.5f, 0.5f}}};
      if (side < 0.0f) std::reverse(corners.begin(), corners.end());
      for (const int corner : {0, 1, 2, 0, 2, 3}) {
        MeshVertex& vertex = vertices[static_cast<std::size_t>(next++)];
        vertex.position[axis] = 0.5f * side;
        vertex.position[u] = corners[static_cast<std::size_t>(corner)][0];
        vertex.position[v] = corners[static_cast<std::size_t>(corner)][1];
        vertex.normal[axis] = side;
      }
    }
  }
  return vertices;
}

// The 12 edges of the cube [-1, 1]^3 as line segments.
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "GL reads them as packed floats");
std::array<Eigen::Vector3f, kEdgeVertexCount> cubeEdgeSegments() {
  std::array<Eigen::Vector3f, kEdgeVertexCount> ends;
  std::size_t next = 0;
  for (int axis = 0; axis < 3; ++axis) {
    for (int across = 0; across < 4; ++across) {
      Eigen::Vector3f end;
      end[(axis + 1) % 3] = across & 1 ? 1.0f : -1.0f;
      end[(axis + 2) % 3] = across & 2 ? 1.0f : -1.0f;
      end[axis] = -1.0f;
      ends[next++] = end;
      end[axis] = 1.0f;
      ends[next++] = end;
    }
  }
  return ends;
}

const void* byteOffset(std::size_t offset) {
  return reinterpret_cast<const void*>(offset);
}

void checkScene(const SceneView& view) {
  const float half = view.interior_half_extent;
  if (!std::isfinite(half) || half <= 0.0f) {
    throw RenderError("cannot render a container of half extent " + std::to_string(half));
  }
  if (view.boxes.size() > static_cast<std::size_t>(std::numeric_limits<GLsizei>::max())) {
    throw RenderError("cannot render " + std::to_string(view.boxes.size()) + " boxes in one draw");
  }
  for (std::size_t i = 0; i < view.boxes.size(); ++i) {
    const BoxInstance& box = view.boxes[i];
    const std::string which = "box " + std::to_string(i);
    if (!box.centre.allFinite()) throw RenderError(which + " has a non-finite centre");
    if (!box.orientation.coeffs().allFinite() || box.orientation.norm() == 0.0f) {
      throw RenderError(which + " has an orientation that is not a rotation");
    }
    if (!std::isfinite(box.edge) || box.edge <= 0.0f) {
      throw RenderError(which + " has edge length " + std::to_string(box.edge));
    }
    if (box.size_class < 0 || box.size_class >= kSizeClassCount) {
      throw RenderError(which + " has size class " + std::to_string(box.size_class) +
                        ", not 0, 1 or 2");
    }
  }
}

}  // namespace

Eigen::Vector3f backgroundColour() {
  return {0.96f, 0.96f, 0.94f};
}

Eigen::Vector3f boxColour(ColourMode mode, const BoxInstance& box) {
  if (mode == ColourMode::kContact) {
    return box.in_contact ? Eigen::Vector3f(0.85f, 0.2f, 0.15f)
                          : Eigen::Vector3f(0.45f, 0.6f, 0.8f);
  }
  static const std::array<Eigen::Vector3f, kSizeClassCount> kBySizeClass = {
      Eigen::Vector3f(0.2f, 0.45f, 0.9f),   // small: blue
      Eigen::Vector3f(0.95f, 0.65f, 0.1f),  // average: amber
      Eigen::Vector3f(0.75f, 0.1f, 0.35f),  // large: crimson
  };
  return kBySizeClass[static_cast<std::size_t>(box.size_class)];
}

struct OffscreenRenderer::Context {
  int width = 0;
  int height = 0;
  ColourMode mode = ColourMode::kSizeClass;
  // OSMesa makes a context current only together with a buffer of its own.
  // The picture goes to a framebuffer object instead, so one pixel will do.
  std::array<std::uint8_t, 4> unused_window_pixel{};
  OsMesaContextHandle osmesa;
  GlFunctions gl{};
  GLuint box_program = 0;
  GLint view_projection_uniform = -1;
  GLuint edge_program = 0;
  GLint edge_transform_uniform = -1;
  GLuint box_vertex_array = 0;
  GLuint instance_buffer = 0;
  GLuint edge_vertex_array = 0;
  std::vector<InstanceAttributes> instances;  // reused between renders

  void makeCurrent() {
    if (!osMesa().MakeCurrent(osmesa.get(), unused_window_pixel.data(), GL_UNSIGNED_BYTE, 1, 1)) {
      throw RenderError("OSMesa cannot make the render context current");
    }
  }

  void createFramebuffer() {
    GLint max_renderbuffer_size = 0;
    GLint max_viewport[2] = {0, 0};
    gl.GetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_renderbuffer_size);
    gl.GetIntegerv(GL_MAX_VIEWPORT_DIMS, max_viewport);
    const GLint limit = std::min({max_renderbuffer_size, max_viewport[0], max_viewport[1]});
    if (width > limit || height > limit) {
      throw ImageSizeError("image size " + std::to_string(width) + "x" + std::to_string(height) +
                           " exceeds this OpenGL's limit of " + std::to_string(limit) +
                           " pixels a side");
    }
    GLuint framebuffer = 0;
    GLuint renderbuffers[2] = {0, 0};
    gl.GenFramebuffers(1, &framebuffer);
    gl.BindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    gl.GenRenderbuffers(2, renderbuffers);
    gl.BindRenderbuffer(GL_RENDERBUFFER, renderbuffers[0]);
    gl.RenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
    gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                               renderbuffers[0]);
    gl.BindRenderbuffer(GL_RENDERBUFFER, renderbuffers[1]);
    gl.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width, height);
    gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER,
                               renderbuffers[1]);
    throwIfGlError(gl, "allocating a " + std::to_string(width) + "x" + std::to_string(height) +
                           " framebuffer");
    const GLenum status = gl.CheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
      // Both formats are ones OpenGL 3.3 must render to: only their
      // storage can be missing.
      throw RendererOutOfMemory("OSMesa cannot allocate the " + std::to_string(width) + "x" +
                                std::to_string(height) + " framebuffer (status " +
                                std::to_string(status) + ")");
    }
  }

  void createBoxGeometry() {
    const auto cube = unitCubeTriangles();
    GLuint buffers[2] = {0, 0};
    gl.GenVertexArrays(1, &box_vertex_array);
    gl.BindVertexArray(box_vertex_array);
    gl.GenBuffers(2, buffers);
    gl.BindBuffer(GL_ARRAY_BUFFER, buffers[0]);
    gl.BufferData(GL_ARRAY_BUFFER, sizeof(cube), cube.data(), GL_STATIC_DRAW);
    gl.EnableVertexAttribArray(kPositionAttribute);
    gl.VertexAttribPointer(kPositionAttribute, 3, GL_FLOAT, GL_FALSE, sizeof(MeshVertex),
                           byteOffset(offsetof(MeshVertex, position)));
    gl.EnableVertexAttribArray(kNormalAttribute);
    gl.VertexAttribPointer(kNormalAttribute, 3, GL_FLOAT, GL_FALSE, sizeof(MeshVertex),
                           byteOffset(offsetof(MeshVertex, normal)));

    instance_buffer = buffers[1];
    gl.BindBuffer(GL_ARRAY_BUFFER, instance_buffer);
    for (GLuint column = 0; column < 4; ++column) {
      const GLuint attribute = kModelMatrixAttribute + column;
      gl.EnableVertexAttribArray(attribute);
      gl.VertexAttribPointer(
          attribute, 4, GL_FLOAT, GL_FALSE, sizeof(InstanceAttributes),
          byteOffset(offsetof(InstanceAttributes, model) + 4 * column * sizeof(float)));
      gl.VertexAttribDivisor(attribute, 1);
    }
    gl.EnableVertexAttribArray(kColourAttribute);
    gl.VertexAttribPointer(kColourAttribute, 3, GL_FLOAT, GL_FALSE, sizeof(InstanceAttributes),
                           byteOffset(offsetof(InstanceAttributes, colour)));
    gl.VertexAttribDivisor(kColourAttribute, 1);
  }

  void createEdgeGeometry() {
    const auto edges = cubeEdgeSegments();
    GLuint buffer = 0;
    gl.GenVertexArrays(1, &edge_vertex_array);
    gl.BindVertexArray(edge_vertex_array);
    gl.GenBuffers(1, &buffer);
    gl.BindBuffer(GL_ARRAY_BUFFER, buffer);
    gl.BufferData(GL_ARRAY_BUFFER, sizeof(edges), edges.data(), GL_STATIC_DRAW);
    gl.EnableVertexAttribArray(kPositionAttribute);
    gl.VertexAttribPointer(kPositionAttribute, 3, GL_FLOAT, GL_FALSE, sizeof(Eigen::Vector3f),
                           byteOffset(0));
  }

  void uploadInstances(std::span<const BoxInstance> boxes) {
    instances.resize(boxes.size());
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const BoxInstance& box = boxes[i];
      const Eigen::Affine3f model = Eigen::Translation3f(box.centre) *
                                    box.orientation.normalized() * Eigen::Scaling(box.edge);
      Eigen::Map<Eigen::Matrix4f>(instances[i].model) = model.matrix();
      Eigen::Map<Eigen::Vector3f>(instances[i].colour) = boxColour(mode, box);
    }
    gl.BindBuffer(GL_ARRAY_BUFFER, instance_buffer);
    gl.BufferData(GL_ARRAY_BUFFER,
                  static_cast<GLsizeiptr>(instances.size() * sizeof(InstanceAttributes)),
                  instances.data(), GL_STREAM_DRAW);
  }
};

OffscreenRenderer::OffscreenRenderer(int width, int height, ColourMode mode)
    : context_(std::make_unique<Context>()) {
  if (width <= 0 || height <= 0) {
    throw ImageSizeError("image size " + std::to_string(width) + "x" + std::to_string(height) +
                         " is not positive");
  }
  Context& c = *context_;
  c.width = width;
  c.height = height;
  c.mode = mode;
  const int attributes[] = {OSMESA_FORMAT,
                            OSMESA_RGBA,
                            OSMESA_DEPTH_BITS,
                            0,
                            OSMESA_STENCIL_BITS,
                            0,
                            OSMESA_ACCUM_BITS,
                            0,
                            OSMESA_PROFILE,
                            OSMESA_CORE_PROFILE,
                            OSMESA_CONTEXT_MAJOR_VERSION,
                            3,
                            OSMESA_CONTEXT_MINOR_VERSION,
                            3,
                            0};
  c.osmesa.reset(osMesa().CreateContextAttribs(attributes, nullptr));
  // This Mesa gives a 3.3 core context (the render tests check it): only
  // memory can be missing.
  if (!c.osmesa) throw RendererOutOfMemory("OSMesa cannot create an OpenGL 3.3 core context");
  c.makeCurrent();
  c.gl = loadGlFunctions();
  c.createFramebuffer();
  c.box_program = buildBoxProgram(c.gl);
  c.view_projection_uniform = requireUniform(c.gl, c.box_program, "view_projection");
  c.edge_program = buildEdgeProgram(c.gl);
  c.edge_transform_uniform = requireUniform(c.gl, c.edge_program, "transform");
  c.createBoxGeometry();
  c.createEdgeGeometry();
  c.gl.Enable(GL_DEPTH_TEST);
  c.gl.Enable(GL_CULL_FACE);
  c.gl.CullFace(GL_BACK);
  const Eigen::Vector3f background = backgroundColour();
  c.gl.ClearColor(background.x(), background.y(), background.z(), 1.0f);
  c.gl.Viewport(0, 0, width, height);
  throwIfGlError(c.gl, "setting up the renderer");
}

OffscreenRenderer::~OffscreenRenderer() = default;
OffscreenRenderer::OffscreenRenderer(OffscreenRenderer&&) noexcept = default;
OffscreenRenderer& OffscreenRenderer::operator=(OffscreenRenderer&&) noexcept = default;

int OffscreenRenderer::width() const {
  return context_->width;
}
int OffscreenRenderer::height() const {
  return context_->height;
}

Image OffscreenRenderer::render(const SceneView& view) {
  checkScene(view);
  Context& c = *context_;
  const GlFunctions& gl = c.gl;
  c.makeCurrent();
  gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

  const Eigen::Matrix4f view_projection = framingViewProjection(
      view.interior_half_extent, static_cast<float>(c.width) / static_cast<float>(c.height));
  if (!view.boxes.empty()) {
    c.uploadInstances(view.boxes);
    gl.UseProgram(c.box_program);
    gl.UniformMatrix4fv(c.view_projection_uniform, 1, GL_FALSE, view_projection.data());
    gl.BindVertexArray(c.box_vertex_array);
    gl.DrawArraysInstanced(GL_TRIANGLES, 0, kCubeVertexCount,
                           static_cast<GLsizei>(view.boxes.size()));
  }
  const Eigen::Matrix4f edge_transform =
      view_projection * Eigen::Affine3f(Eigen::Scaling(view.interior_half_extent)).matrix();
  gl.UseProgram(c.edge_program);
  gl.UniformMatrix4fv(c.edge_transform_uniform, 1, GL_FALSE, edge_transform.data());
  gl.BindVertexArray(c.edge_vertex_array);
  gl.DrawArrays(GL_LINES, 0, kEdgeVertexCount);
  throwIfGlError(gl, "drawing " + std::to_string(view.boxes.size()) + " boxes");

  Image image{c.width, c.height, {}};
  const std::size_t row_bytes = 4 * static_cast<std::size_t>(c.width);
  image.rgba.resize(row_bytes * static_cast<std::size_t>(c.height));
  gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
  gl.ReadPixels(0, 0, c.width, c.height, GL_RGBA, GL_UNSIGNED_BYTE, image.rgba.data());
  throwIfGlError(gl, "reading back the image");
  // GL's first row is the bottom one; images store the top one first.
  for (std::size_t top = 0, bottom = static_cast<std::size_t>(c.height) - 1; top < bottom;
       ++top, --bottom) {
    std::swap_ranges(image.rgba.begin() + static_cast<std::ptrdiff_t>(top * row_bytes),
                     image.rgba.begin() + static_cast<std::ptrdiff_t>((top + 1) * row_bytes),
                     image.rgba.begin() + static_cast<std::ptrdiff_t>(bottom * row_bytes));
  }
  return image;
}

}  // namespace overlap::render
