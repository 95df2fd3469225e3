// The fixed camera every capture uses, and the matrix math behind it.
//
// The camera looks at the container's centre from a raised corner (from the
// direction (1, 0.8, 1.4)), with +y up, from 3.5 times the interior's
// bounding radius, so a scene of any size L is seen with the same
// perspective.  The picture is then zoomed and shifted so that the interior's
// eight corners span 90% of the frame along its tighter axis, centred, and
// motion stays readable.
//
// Conventions are OpenGL's: right-handed eye space looking down -z, clip space
// with z in [-w, w].  Matrices are column-major Eigen matrices, ready for
// glUniformMatrix4fv.
#pragma once

#include <Eigen/Core>

namespace overlap::render {

// View matrix of a camera at eye looking at target; up must not be parallel
// to target - eye.
Eigen::Matrix4f lookAt(const Eigen::Vector3f& eye, const Eigen::Vector3f& target,
                       const Eigen::Vector3f& up);

// Perspective projection; 0 < near_plane < far_plane, aspect = width / height.
Eigen::Matrix4f perspective(float vertical_fov_radians, float aspect, float near_plane,
                            float far_plane);

// Clip-from-world matrix of the capture camera for a container whose interior
// is [-half_extent, half_extent]^3, for an image of the given aspect.
Eigen::Matrix4f framingViewProjection(float half_extent, float aspect);

}  // namespace overlap::render
