#include "render/camera.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace overlap::render {
namespace {

Eigen::Vector3f project(const Eigen::Matrix4f& clip_from_world, const Eigen::Vector3f& point) {
  const Eigen::Vector4f clip = clip_from_world * point.homogeneous();
  return clip.head<3>() / clip.w();
}

TEST(LookAt, PutsTheEyeAtTheOriginAndTheTargetDownMinusZ) {
  const Eigen::Vector3f eye(3, 4, 5);
  const Eigen::Vector3f target(-1, 0, 2);
  const Eigen::Matrix4f view = lookAt(eye, target, Eigen::Vector3f::UnitY());
  EXPECT_TRUE((view * eye.homogeneous()).head<3>().isZero(1e-5f));
  const Eigen::Vector3f seen = (view * target.homogeneous()).head<3>();
  EXPECT_NEAR(seen.x(), 0.0f, 1e-5f);
  EXPECT_NEAR(seen.y(), 0.0f, 1e-5f);
  EXPECT_NEAR(seen.z(), -(target - eye).norm(), 1e-5f);
  // A rigid motion: lengths are kept.
  EXPECT_TRUE(
      (view.topLeftCorner<3, 3>() * view.topLeftCorner<3, 3>().transpose()).isIdentity(1e-5f));
}

TEST(Perspective, MapsTheNearAndFarPlanesToTheEndsOfTheDepthRange) {
  const Eigen::Matrix4f projection = perspective(0.8f, 1.5f, 2.0f, 50.0f);
  EXPECT_NEAR(project(projection, {0, 0, -2}).z(), -1.0f, 1e-5f);
  EXPECT_NEAR(project(projection, {0, 0, -50}).z(), 1.0f, 1e-5f);
  // The top of the field of view at depth 10 lands on the top of the image.
  EXPECT_NEAR(project(projection, {0, 10 * std::tan(0.4f), -10}).y(), 1.0f, 1e-5f);
}

Eigen::AlignedBox2f projectedCorners(float half_extent, float aspect) {
  const Eigen::Matrix4f clip_from_world = framingViewProjection(half_extent, aspect);
  Eigen::AlignedBox2f extent;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3f ndc =
        project(clip_from_world, Eigen::Vector3f(corner & 1 ? half_extent : -half_extent,
                                                 corner & 2 ? half_extent : -half_extent,
                                                 corner & 4 ? half_extent : -half_extent));
    EXPECT_GT(ndc.z(), -1.0f) << "corner " << corner << " is in front of the near plane";
    EXPECT_LT(ndc.z(), 1.0f) << "corner " << corner << " is beyond the far plane";
    extent.extend(ndc.head<2>());
  }
  return extent;
}

TEST(FramingViewProjection, CornersSpanNinetyPercentOfTheFrameCentred) {
  for (const float half_extent : {0.5f, 16.35f, 300.0f}) {
    for (const float aspect : {4.0f / 3.0f, 1.0f, 0.5f, 2.5f}) {
      const Eigen::AlignedBox2f extent = projectedCorners(half_extent, aspect);
      EXPECT_NEAR(extent.sizes().maxCoeff(), 1.8f, 1e-4f) << half_extent << " " << aspect;
      EXPECT_TRUE(extent.center().isZero(1e-4f)) << half_extent << " " << aspect;
    }
  }
}

TEST(FramingViewProjection, LooksDownOnTheContainer) {
  // From above, the floor's nearest corner shows below the ceiling corner
  // over it and below the floor's farthest corner.
  const Eigen::Matrix4f clip_from_world = framingViewProjection(1.0f, 1.0f);
  EXPECT_LT(project(clip_from_world, {1, -1, 1}).y(), project(clip_from_world, {1, 1, 1}).y());
  EXPECT_LT(project(clip_from_world, {1, -1, 1}).y(), project(clip_from_world, {-1, -1, -1}).y());
}

}  // namespace
}  // namespace overlap::render
