// rostest (scene_markers.test): ~markers holds hair, head and obstacles, as RViz shows them.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <ros/ros.h>
#include <visualization_msgs/MarkerArray.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "ros_test_helpers.h"
#include "wet_curly_hair/LoadObstacleMap.h"

using visualization_msgs::Marker;
using visualization_msgs::MarkerArray;
using wch_test::Latest;

namespace {

/// The markers of one namespace, by id (a DELETE is not a marker that is drawn).
std::map<int, Marker> inNamespace(const MarkerArray& a, const std::string& ns) {
  std::map<int, Marker> out;
  for (const Marker& m : a.markers)
    if (m.ns == ns && m.action == Marker::ADD) {
      EXPECT_EQ(out.count(m.id), 0u) << ns << " id " << m.id << " twice";
      out[m.id] = m;
    }
  return out;
}

/// Keeps the recent strands messages by stamp, to pair them with the markers of the same frame.
class StrandsByStamp {
 public:
  explicit StrandsByStamp(ros::NodeHandle& nh)
      : sub_(nh.subscribe("/wet_curly_hair/strands", 100, &StrandsByStamp::onMessage, this)) {}
  ~StrandsByStamp() { sub_.shutdown(); }
  bool find(const ros::Time& stamp, wet_curly_hair::Strands* out) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = by_stamp_.find(stamp.toNSec());
    if (it == by_stamp_.end()) return false;
    *out = *it->second;
    return true;
  }

 private:
  void onMessage(const wet_curly_hair::Strands::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    by_stamp_[m->header.stamp.toNSec()] = m;
    while (by_stamp_.size() > 300) by_stamp_.erase(by_stamp_.begin());
  }
  ros::Subscriber sub_;
  std::mutex mutex_;
  std::map<uint64_t, wet_curly_hair::Strands::ConstPtr> by_stamp_;
};

/// A marker array and the strands message of the same frame, once the head pose was taken.
void pairedFrame(Latest<MarkerArray>* markers, StrandsByStamp* strands, MarkerArray* a,
                 wet_curly_hair::Strands* s) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(30.0);
  while (ros::ok() && ros::WallTime::now() < end) {
    if (markers->next(5.0, a) && !a->markers.empty() &&
        strands->find(a->markers[0].header.stamp, s) && s->reset_count >= 1 && s->step > 2)
      return;
  }
  ADD_FAILURE() << "no marker array paired with a strands message of the same stamp in 30 s";
}

double quatAngle(const geometry_msgs::Quaternion& a, const geometry_msgs::Quaternion& b) {
  const double d = std::abs(a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z);
  return 2.0 * std::acos(std::min(1.0, d));
}

TEST(SceneMarkers, HairHeadAndAnalyticObstaclesAreThere) {
  ros::NodeHandle nh;
  Latest<MarkerArray> markers(nh, "/wet_curly_hair/markers");
  StrandsByStamp strands(nh);
  MarkerArray a;
  wet_curly_hair::Strands s;
  pairedFrame(&markers, &strands, &a, &s);
  ASSERT_FALSE(a.markers.empty());
  for (const Marker& m : a.markers) EXPECT_EQ(m.header.frame_id, "world") << m.ns;

  // The hair: one LINE_LIST, drawn from the display positions p^w (cohesion "ours" by default).
  const auto hair = inNamespace(a, "wet_curly_hair/strands");
  ASSERT_EQ(hair.size(), 1u);
  const Marker& l = hair.begin()->second;
  EXPECT_EQ(l.type, Marker::LINE_LIST);
  ASSERT_EQ(l.points.size(), 2u * (24 * 16 - 24));
  ASSERT_EQ(s.wet_positions.size(), s.positions.size());
  double wet_shift = 0.0, from_wet = 0.0;
  size_t k = 0;
  for (size_t st = 0; st + 1 < s.strand_offsets.size(); ++st)
    for (uint32_t i = s.strand_offsets[st]; i + 1 < s.strand_offsets[st + 1]; ++i, k += 2) {
      const float* w = &s.wet_positions[3 * i];
      const float* x = &s.positions[3 * i];
      from_wet = std::max({from_wet, std::abs(l.points[k].x - w[0]), std::abs(l.points[k].y - w[1]),
                           std::abs(l.points[k].z - w[2])});
      wet_shift = std::max({wet_shift, std::abs(double(w[0]) - x[0]), std::abs(double(w[1]) - x[1]),
                            std::abs(double(w[2]) - x[2])});
    }
  EXPECT_LT(from_wet, 1e-6) << "the hair marker is not drawn from wet_positions";
  EXPECT_GT(wet_shift, 1e-4) << "p^w equals x everywhere: this frame cannot tell them apart";

  // The head: the built-in ellipsoid and its neck capsule (a cylinder and two end spheres), at
  // the head pose the solver used for this frame.
  const auto head = inNamespace(a, "wet_curly_hair/head");
  ASSERT_EQ(head.size(), 4u);
  const Marker& e = head.at(0);
  EXPECT_EQ(e.type, Marker::SPHERE);
  EXPECT_NEAR(e.scale.x, 2 * 0.095, 1e-9);
  EXPECT_NEAR(e.scale.y, 2 * 0.078, 1e-9);
  EXPECT_NEAR(e.scale.z, 2 * 0.11, 1e-9);
  EXPECT_NEAR(e.pose.position.x, s.head_pose.position.x, 1e-9);
  EXPECT_NEAR(e.pose.position.y, s.head_pose.position.y, 1e-9);
  EXPECT_NEAR(e.pose.position.z, s.head_pose.position.z, 1e-9);
  EXPECT_LT(quatAngle(e.pose.orientation, s.head_pose.orientation), 1e-6);
  EXPECT_EQ(head.at(1).type, Marker::CYLINDER);
  EXPECT_EQ(head.at(2).type, Marker::SPHERE);
  EXPECT_EQ(head.at(3).type, Marker::SPHERE);
  EXPECT_NEAR(head.at(1).scale.x, 2 * 0.055, 1e-9);

  // The obstacles, in the order of ~obstacles.
  const auto obstacles = inNamespace(a, "wet_curly_hair/obstacles");
  ASSERT_EQ(obstacles.size(), 3u);
  const Marker& sphere = obstacles.at(0);
  EXPECT_EQ(sphere.type, Marker::SPHERE);
  EXPECT_NEAR(sphere.scale.x, 0.12, 1e-9);
  EXPECT_NEAR(sphere.pose.position.x, -0.17, 1e-9);
  EXPECT_NEAR(sphere.pose.position.z, -0.06, 1e-9);
  const Marker& box = obstacles.at(1);
  EXPECT_EQ(box.type, Marker::CUBE);
  EXPECT_NEAR(box.scale.x, 0.08, 1e-9);
  EXPECT_NEAR(box.scale.y, 0.10, 1e-9);
  EXPECT_NEAR(box.scale.z, 0.12, 1e-9);
  EXPECT_NEAR(box.pose.position.y, 0.25, 1e-9);
  const Marker& plane = obstacles.at(2);
  EXPECT_EQ(plane.type, Marker::CUBE);
  EXPECT_NEAR(plane.pose.position.z + 0.5 * plane.scale.z, -0.45, 1e-9) << "top face off the plane";
  EXPECT_GT(plane.scale.x, 0.5);
  EXPECT_EQ(inNamespace(a, "wet_curly_hair/obstacle_field").size(), 0u) << "no map loaded yet";
}

TEST(SceneMarkers, TheHeadMarkerFollowsTheNod) {
  ros::NodeHandle nh;
  Latest<MarkerArray> markers(nh, "/wet_curly_hair/markers");
  StrandsByStamp strands(nh);
  MarkerArray a, b;
  wet_curly_hair::Strands s;
  pairedFrame(&markers, &strands, &a, &s);
  const auto first = inNamespace(a, "wet_curly_hair/head");
  ASSERT_EQ(first.count(0), 1u);
  // Over half a period of the 0.5 Hz, 0.3 rad nod the head turns by much more than 0.05 rad.
  double turned = 0.0;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(10.0);
  while (turned < 0.05 && ros::WallTime::now() < end) {
    pairedFrame(&markers, &strands, &b, &s);
    const auto now = inNamespace(b, "wet_curly_hair/head");
    ASSERT_EQ(now.count(0), 1u);
    EXPECT_LT(quatAngle(now.at(0).pose.orientation, s.head_pose.orientation), 1e-6);
    turned = quatAngle(first.at(0).pose.orientation, now.at(0).pose.orientation);
  }
  EXPECT_GE(turned, 0.05) << "the head marker did not turn with the head in 10 s";
}

TEST(SceneMarkers, AnOctomapFieldIsDrawnAsItsSurfaceAndRemovedWithIt) {
  ros::NodeHandle nh;
  Latest<MarkerArray> markers(nh, "/wet_curly_hair/markers");
  // A solid ball of occupied voxels below the head, where the hair hangs, in free space. Sampled
  // at voxel centres, so that every voxel is set once (no holes from rounding).
  const double cx = 0.12, cy = 0.0, cz = -0.2, r = 0.05, res = 0.01;
  octomap::OcTree tree(res);
  const int n = static_cast<int>(std::ceil(r / res)) + 2;
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int k = -n; k <= n; ++k) {
        const double x = (std::floor(cx / res) + i + 0.5) * res,
                     y = (std::floor(cy / res) + j + 0.5) * res,
                     z = (std::floor(cz / res) + k + 0.5) * res;
        const double d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz);
        tree.updateNode(octomap::point3d(x, y, z), d2 <= r * r);
      }
  tree.updateInnerOccupancy();
  const std::string path = "/tmp/wch_test_scene_markers_" + std::to_string(getpid()) + ".bt";
  ASSERT_TRUE(tree.writeBinary(path));
  ros::ServiceClient load =
      nh.serviceClient<wet_curly_hair::LoadObstacleMap>("/wet_curly_hair/load_obstacle_map");
  wet_curly_hair::LoadObstacleMap srv;
  srv.request.path = path;
  ASSERT_TRUE(wch_test::call(load, &srv));
  ASSERT_TRUE(srv.response.success) << srv.response.message;

  MarkerArray a;
  ASSERT_TRUE(markers.waitFor(
      20.0,
      [](const MarkerArray& m) { return !inNamespace(m, "wet_curly_hair/obstacle_field").empty(); },
      &a))
      << "no obstacle_field marker within 20 s of loading the map";
  const Marker f = inNamespace(a, "wet_curly_hair/obstacle_field").at(0);
  EXPECT_EQ(f.type, Marker::CUBE_LIST);
  EXPECT_GT(f.points.size(), 100u);
  EXPECT_LE(f.points.size(), 10000u);
  EXPECT_GT(f.scale.x, 0.0);
  // Every cube lies on the ball's surface (within a voxel and a half: voxel centres, the
  // field's resolution) - the surface, not the interior, and nothing elsewhere.
  double nearest = 1e9, farthest = 0.0;
  for (const auto& p : f.points) {
    const double x = p.x + f.pose.position.x, y = p.y + f.pose.position.y,
                 z = p.z + f.pose.position.z;  // the field frame is the world frame here
    const double d = std::sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz));
    nearest = std::min(nearest, d);
    farthest = std::max(farthest, d);
  }
  std::printf("[ field    ] %zu cubes of %.3f m, %.3f to %.3f m from the ball's centre (r %.3f)\n",
              f.points.size(), f.scale.x, nearest, farthest, r);
  EXPECT_GT(nearest, r - 1.5 * f.scale.x);
  EXPECT_LT(farthest, r + 1.5 * f.scale.x);

  // Removing the map deletes the marker in RViz (sent once: every array is looked at).
  std::atomic<bool> deleted{false};
  ros::Subscriber watch = nh.subscribe<MarkerArray>(
      "/wet_curly_hair/markers", 50, [&deleted](const MarkerArray::ConstPtr& m) {
        for (const Marker& k : m->markers)
          if (k.ns == "wet_curly_hair/obstacle_field" && k.action == Marker::DELETE) deleted = true;
      });
  srv.request.path = "";
  ASSERT_TRUE(wch_test::call(load, &srv));
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(20.0);
  while (!deleted && ros::WallTime::now() < end) ros::WallDuration(0.01).sleep();
  watch.shutdown();
  EXPECT_TRUE(deleted) << "no DELETE of the obstacle_field marker after the map was removed";
  std::remove(path.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_scene_markers");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
