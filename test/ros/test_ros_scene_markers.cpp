// gtest without a master: the head, obstacle and obstacle-field markers (conversions.h).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "wet_curly_hair/ros/conversions.h"

namespace wet_curly_hair {
namespace {

using visualization_msgs::Marker;
using visualization_msgs::MarkerArray;

Vec3 position(const Marker& m) {
  return Vec3(m.pose.position.x, m.pose.position.y, m.pose.position.z);
}
Quat orientation(const Marker& m) {
  return Quat(m.pose.orientation.w, m.pose.orientation.x, m.pose.orientation.y,
              m.pose.orientation.z);
}

TEST(SceneMarkers, HeadShapesArePlacedByTheHeadPose) {
  HeadShape head;
  head.ellipsoid.center_m = Vec3(0.01, 0.0, 0.02);
  head.ellipsoid.radii_m = Vec3(0.09, 0.08, 0.11);
  head.capsules.push_back({"neck", Vec3(0.0, 0.0, -0.06), Vec3(0.0, 0.0, -0.26), 0.05});
  Pose pose;
  pose.translation = Vec3(1.0, 2.0, 3.0);
  pose.rotation = Quat(Eigen::AngleAxisd(0.5, Vec3::UnitY()));
  std_msgs::Header h;
  h.frame_id = "world";
  MarkerArray a;
  appendHeadMarkers(head, pose, h, &a);
  ASSERT_EQ(a.markers.size(), 4u);
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(a.markers[k].ns, kHeadMarkerNs);
    EXPECT_EQ(a.markers[k].id, static_cast<int>(k));
    EXPECT_EQ(a.markers[k].header.frame_id, "world");
  }
  const Marker& e = a.markers[0];
  EXPECT_EQ(e.type, Marker::SPHERE);
  EXPECT_LT((position(e) - pose.apply(head.ellipsoid.center_m)).norm(), 1e-12);
  EXPECT_LT(orientation(e).angularDistance(pose.rotation), 1e-9);
  EXPECT_DOUBLE_EQ(e.scale.z, 0.22);
  // The capsule: a cylinder between the two ends, spheres of the capsule's diameter on them.
  const Marker& body = a.markers[1];
  EXPECT_EQ(body.type, Marker::CYLINDER);
  const Vec3 a_w = pose.apply(head.capsules[0].a_m), b_w = pose.apply(head.capsules[0].b_m);
  EXPECT_LT((position(body) - 0.5 * (a_w + b_w)).norm(), 1e-12);
  EXPECT_LT((orientation(body) * Vec3::UnitZ() - (b_w - a_w).normalized()).norm(), 1e-9);
  EXPECT_NEAR(body.scale.z, 0.2, 1e-12);
  EXPECT_DOUBLE_EQ(body.scale.x, 0.1);
  EXPECT_EQ(a.markers[2].type, Marker::SPHERE);
  EXPECT_LT((position(a.markers[2]) - a_w).norm(), 1e-12);
  EXPECT_LT((position(a.markers[3]) - b_w).norm(), 1e-12);
  EXPECT_DOUBLE_EQ(a.markers[3].scale.x, 0.1);
}

TEST(SceneMarkers, AnalyticObstaclesOneMarkerEach) {
  std::vector<AnalyticObstacle> obstacles(3);
  std::string why;
  ASSERT_TRUE(AnalyticObstacle::parse("sphere:x=0.1,y=0.2,z=0.3,r=0.05", &obstacles[0], &why));
  ASSERT_TRUE(
      AnalyticObstacle::parse("box:x=0,y=0,z=-1,hx=0.1,hy=0.2,hz=0.3", &obstacles[1], &why));
  ASSERT_TRUE(AnalyticObstacle::parse("plane:x=5,y=5,z=-0.5,nx=0,ny=1,nz=1", &obstacles[2], &why));
  MarkerArray a;
  const Vec3 head(0.2, -0.1, 0.4);
  appendObstacleMarkers(obstacles, head, 1.5, std_msgs::Header(), &a);
  ASSERT_EQ(a.markers.size(), 3u);
  EXPECT_EQ(a.markers[0].type, Marker::SPHERE);
  EXPECT_DOUBLE_EQ(a.markers[0].scale.y, 0.1);
  EXPECT_LT((position(a.markers[0]) - Vec3(0.1, 0.2, 0.3)).norm(), 1e-12);
  EXPECT_EQ(a.markers[1].type, Marker::CUBE);
  EXPECT_DOUBLE_EQ(a.markers[1].scale.y, 0.4);
  // The plane: a thin square whose top face lies on the plane, centred under the head.
  const Marker& p = a.markers[2];
  EXPECT_EQ(p.type, Marker::CUBE);
  EXPECT_EQ(p.id, 2);
  EXPECT_DOUBLE_EQ(p.scale.x, 1.5);
  const Vec3 n = Vec3(0, 1, 1).normalized();
  EXPECT_LT((orientation(p) * Vec3::UnitZ() - n).norm(), 1e-9);
  const Vec3 top = position(p) + 0.5 * p.scale.z * n;
  Vec3 normal;
  EXPECT_NEAR(obstacles[2].distance(top, &normal), 0.0, 1e-12);
  EXPECT_LT((top - head).cross(n).norm(), 1e-12) << "not the foot of the head on the plane";
}

/// A field whose lower half (k < nz / 2) is solid: its surface is the layer below the middle,
/// plus the solid's faces on the grid's sides and bottom (outside the grid counts as free).
ObstacleField slabField(int nx, int ny, int nz, double voxel) {
  auto sdf = std::make_shared<DenseSdf>();
  sdf->origin_m = Vec3(-1.0, 0.0, 0.5);
  sdf->voxel_m = voxel;
  sdf->dims = Eigen::Vector3i(nx, ny, nz);
  sdf->distance_m.resize(static_cast<size_t>(nx) * ny * nz);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        sdf->distance_m[sdf->index(i, j, k)] = static_cast<float>((k - nz / 2 + 0.5) * voxel);
  ObstacleField f;
  f.sdf = sdf;
  f.field_in_world.translation = Vec3(0.0, 0.0, 1.0);
  return f;
}

TEST(SceneMarkers, FieldSurfaceVoxelsAsOneCubeList) {
  const ObstacleField f = slabField(10, 8, 6, 0.02);
  Marker m;
  ASSERT_EQ(obstacleFieldMarker(f, 10000, std_msgs::Header(), &m), 1);
  EXPECT_EQ(m.type, Marker::CUBE_LIST);
  EXPECT_EQ(m.ns, kObstacleFieldMarkerNs);
  EXPECT_DOUBLE_EQ(m.scale.x, 0.02);
  EXPECT_DOUBLE_EQ(m.pose.position.z, 1.0);  // placed by field_in_world
  // Solid: k = 0..2. Surface: the top layer k = 2 and the bottom layer k = 0 (80 each; below
  // the grid counts as free) and the border ring of k = 1 (2 * (10 + 8) - 4 = 32 voxels).
  EXPECT_EQ(m.points.size(), 80u + 80u + 32u);
  for (const auto& p : m.points) EXPECT_LE(p.z, 0.5 + 2 * 0.02 + 1e-12);
  // No field, or a bound of 0: an empty list and 0.
  EXPECT_EQ(obstacleFieldMarker(ObstacleField(), 10000, std_msgs::Header(), &m), 0);
  EXPECT_TRUE(m.points.empty());
}

TEST(SceneMarkers, ALargeFieldIsMergedIntoBlocksUnderTheBound) {
  const double voxel = 0.01;
  const ObstacleField f = slabField(300, 300, 8, voxel);  // a 3 m x 3 m floor: 90,000+ voxels
  Marker m;
  const int block = obstacleFieldMarker(f, 10000, std_msgs::Header(), &m);
  ASSERT_GE(block, 2);
  EXPECT_LE(m.points.size(), 10000u);
  EXPECT_GT(m.points.size(), 10000u / 4) << "merged much more than needed";
  EXPECT_DOUBLE_EQ(m.scale.x, block * voxel);
  // Every block is centred on a block of the grid and holds a surface voxel (k = 0 or 3, or a
  // side face).
  for (const auto& p : m.points) {
    const double bi = (p.x - (-1.0)) / voxel - 0.5 * (block - 1);
    ASSERT_NEAR(bi / block, std::round(bi / block), 1e-6);
    const double k = (p.z - 0.5) / voxel;
    ASSERT_LE(k - 0.5 * block, 3.0 + 1e-9);
  }
}

TEST(SceneMarkers, VanishedMarkersAreDeletedOnce) {
  std::set<std::pair<std::string, int32_t>> published;
  std::vector<AnalyticObstacle> two(2);
  MarkerArray a;
  appendObstacleMarkers(two, Vec3::Zero(), 1.0, std_msgs::Header(), &a);
  deleteVanishedMarkers(&published, &a);
  EXPECT_EQ(a.markers.size(), 2u);  // nothing published before: nothing to delete
  MarkerArray b;
  two.pop_back();
  appendObstacleMarkers(two, Vec3::Zero(), 1.0, std_msgs::Header(), &b);
  deleteVanishedMarkers(&published, &b);
  ASSERT_EQ(b.markers.size(), 2u);
  EXPECT_EQ(b.markers[1].action, Marker::DELETE);
  EXPECT_EQ(b.markers[1].ns, kObstacleMarkerNs);
  EXPECT_EQ(b.markers[1].id, 1);
  MarkerArray c;
  appendObstacleMarkers(two, Vec3::Zero(), 1.0, std_msgs::Header(), &c);
  deleteVanishedMarkers(&published, &c);
  EXPECT_EQ(c.markers.size(), 1u) << "a DELETE sent twice";
}

}  // namespace
}  // namespace wet_curly_hair
