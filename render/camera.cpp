#include "render/camera.h"

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

namespace overlap::render {
namespace {

constexpr float kVerticalFov = 30.0f * std::numbers::pi_v<float> / 180.0f;
// Far enough that the perspective stays mild, near enough that depth reads.
constexpr float kDistanceInBoundingRadii = 3.5f;
constexpr float kFrameFill = 0.9f;  // the share of the frame the container spans

}  // namespace

Eigen::Matrix4f lookAt(const Eigen::Vector3f& eye, const Eigen::Vector3f& target,
                       const Eigen::Vector3f& up) {
  const Eigen::Vector3f forward = (target - eye).normalized();
  const Eigen::Vector3f right = forward.cross(up).normalized();
  const Eigen::Vector3f camera_up = right.cross(forward);
  Eigen::Matrix4f view = Eigen::Matrix4f::Identity();
  view.block<1, 3>(0, 0) = right.transpose();
  view.block<1, 3>(1, 0) = camera_up.transpose();
  view.block<1, 3>(2, 0) = -forward.transpose();
  view(0, 3) = -right.dot(eye);
  view(1, 3) = -camera_up.dot(eye);
  view(2, 3) = forward.dot(eye);
  return view;
}

Eigen::Matrix4f perspective(float vertical_fov_radians, float aspect, float near_plane,
                            float far_plane) {
  const float focal = 1.0f / std::tan(vertical_fov_radians / 2.0f);
  Eigen::Matrix4f projection = Eigen::Matrix4f::Zero();
  projection(0, 0) = focal / aspect;
  projection(1, 1) = focal;
  projection(2, 2) = (far_plane + near_plane) / (near_plane - far_plane);
  projection(2, 3) = 2.0f * far_plane * near_plane / (near_plane - far_plane);
  projection(3, 2) = -1.0f;
  return projection;
}

Eigen::Matrix4f framingViewProjection(float half_extent, float aspect) {
  const float bounding_radius = std::sqrt(3.0f) * half_extent;
  const float distance = kDistanceInBoundingRadii * bounding_radius;
  const Eigen::Vector3f towards_camera = Eigen::Vector3f(1.0f, 0.8f, 1.4f).normalized();
  const Eigen::Matrix4f view =
      lookAt(distance * towards_camera, Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitY());
  // Boxes may poke past the interior into the walls; the depth range keeps
  // anything within half a bounding radius beyond it.
  const float depth_margin = 1.5f * bounding_radius;
  const Eigen::Matrix4f clip_from_world =
      perspective(kVerticalFov, aspect, distance - depth_margin, distance + depth_margin) * view;

  // Seen from above, the container's picture is not centred on its centre.
  // Zoom and shift the image plane (a lens shift: the perspective stays the
  // same) so the corners' extent is centred and fills kFrameFill of the frame.
  Eigen::AlignedBox2f extent;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector4f clip =
        clip_from_world * Eigen::Vector4f(corner & 1 ? half_extent : -half_extent,
                                          corner & 2 ? half_extent : -half_extent,
                                          corner & 4 ? half_extent : -half_extent, 1.0f);
    extent.extend(Eigen::Vector2f(clip.x(), clip.y()) / clip.w());
  }
  const float zoom = 2.0f * kFrameFill / extent.sizes().maxCoeff();
  Eigen::Matrix4f lens_shift = Eigen::Matrix4f::Identity();
  lens_shift.topLeftCorner<2, 2>() *= zoom;
  lens_shift.block<2, 1>(0, 3) = -zoom * extent.center();
  return lens_shift * clip_from_world;
}

}  // namespace overlap::render
