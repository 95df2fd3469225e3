// The renderer's two GLSL 3.30 core programs and how they are built.
//
// Box program: one unit cube mesh (attributes 0 = position, 1 = normal) drawn
// instanced; each instance carries its model matrix (attributes 2..5, one
// column each) and its base colour (attribute 6).  The model matrix must be a
// rotation times a uniform scale plus a translation, so that its upper 3x3
// maps normals to normals.  Lighting is Lambert: a fixed directional light
// plus ambient.  Uniform: view_projection.
//
// Edge program: unlit lines (attribute 0 = position) in one dark colour.
// Uniform: transform (clip from model).
#pragma once

#include "render/gl_loader.h"

namespace overlap::render {

inline constexpr GLuint kPositionAttribute = 0;
inline constexpr GLuint kNormalAttribute = 1;
inline constexpr GLuint kModelMatrixAttribute = 2;  // four consecutive locations
inline constexpr GLuint kColourAttribute = 6;

GLuint buildBoxProgram(const GlFunctions& gl);
GLuint buildEdgeProgram(const GlFunctions& gl);

// The location of a uniform the program must have; throws RenderError if the
// linker dropped or never saw it.
GLint requireUniform(const GlFunctions& gl, GLuint program, const char* name);

}  // namespace overlap::render
