// rostest (obstacles.test): obstacle maps from files and from the octomap_binary topic.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <topic_tools/shape_shifter.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "ros_test_helpers.h"
#include "wet_curly_hair/GetParameters.h"
#include "wet_curly_hair/LoadObstacleMap.h"
#include "wet_curly_hair/OctomapCompat.h"
#include "wet_curly_hair/SetParameters.h"

using wch_test::Latest;
using wet_curly_hair::LoadObstacleMap;
using wet_curly_hair::OctomapCompat;
using wet_curly_hair::Status;

namespace {

/// A solid sphere of occupied voxels (and free space around it).
octomap::OcTree sphereTree(double cx, double cy, double cz, double r, double res) {
  octomap::OcTree tree(res);
  for (double x = -r - 2 * res; x <= r + 2 * res; x += res)
    for (double y = -r - 2 * res; y <= r + 2 * res; y += res)
      for (double z = -r - 2 * res; z <= r + 2 * res; z += res)
        tree.updateNode(octomap::point3d(cx + x, cy + y, cz + z), x * x + y * y + z * z <= r * r);
  tree.updateInnerOccupancy();
  return tree;
}

std::string tempPath(const std::string& name) {
  return "/tmp/wch_test_obstacles_" + std::to_string(getpid()) + "_" + name;
}

class NodeObstacles : public testing::Test {
 protected:
  NodeObstacles()
      : status_(nh_, "/wet_curly_hair/status"),
        load_(nh_.serviceClient<LoadObstacleMap>("/wet_curly_hair/load_obstacle_map")) {}
  Status nextStatus() {
    Status s;
    EXPECT_TRUE(status_.next(20.0, &s));
    return s;
  }
  LoadObstacleMap::Response load(const std::string& path, const std::string& frame = "") {
    LoadObstacleMap srv;
    srv.request.path = path;
    srv.request.frame_id = frame;
    EXPECT_TRUE(wch_test::call(load_, &srv));
    std::printf("[ load     ] '%s' in '%s': %s: %s\n", path.c_str(), frame.c_str(),
                srv.response.success ? "ok" : "refused", srv.response.message.c_str());
    return srv.response;
  }
  ros::NodeHandle nh_;
  Latest<Status> status_;
  ros::ServiceClient load_;
};

TEST_F(NodeObstacles, FilesLoadBadOnesAreRefusedAndThePreviousFieldStays) {
  // Hair hangs below and behind the head (at the world origin): a ball there.
  const std::string good = tempPath("sphere.bt");
  ASSERT_TRUE(sphereTree(-0.08, 0.0, -0.2, 0.06, 0.01).writeBinary(good));
  const std::string garbage = tempPath("garbage.bt");
  std::ofstream(garbage) << "# Octomap OcTree binary file\nid OcTree\nsize 12\nres 0.01\ndata\n"
                         << "\x01\x02\x03";
  const uint32_t refused0 = nextStatus().obstacle_maps_refused;

  LoadObstacleMap::Response r = load(good);
  ASSERT_TRUE(r.success) << r.message;
  Status s;
  ASSERT_TRUE(status_.waitFor(
      10.0, [&](const Status& m) { return m.obstacle_field_loaded; }, &s));
  EXPECT_EQ(s.obstacle_field_source, good);
  EXPECT_GT(s.obstacle_field_cells, 0);
  EXPECT_GT(s.obstacle_field_build_time_s, 0.0);
  EXPECT_GE(s.obstacle_field_age_s, 0.0);
  EXPECT_GE(s.obstacle_map_age_s, 0.0);
  ASSERT_TRUE(status_.waitFor(10.0, [](const Status& m) { return m.strands_near_obstacles > 0; }))
      << "the field does not reach the solver";

  for (const std::string& bad : {tempPath("missing.bt"), garbage}) {
    r = load(bad);
    EXPECT_FALSE(r.success);
    EXPECT_NE(r.message.find("previous field stays"), std::string::npos) << r.message;
  }
  r = load(good, "nowhere");  // a frame that never resolves
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("nowhere"), std::string::npos) << r.message;
  s = nextStatus();
  EXPECT_EQ(s.obstacle_maps_refused, refused0 + 3);
  EXPECT_NE(s.obstacle_last_error, "");
  EXPECT_TRUE(s.obstacle_field_loaded) << "a refused map removed the previous field";
  EXPECT_EQ(s.obstacle_field_source, good);

  // A map in a frame of its own, placed over tf2.
  tf2_ros::StaticTransformBroadcaster static_br;
  geometry_msgs::TransformStamped t;
  t.header.stamp = ros::Time::now();
  t.header.frame_id = "world";
  t.child_frame_id = "scanner";
  t.transform.translation.x = -0.08;
  t.transform.translation.z = -0.2;
  t.transform.rotation.w = 1.0;
  static_br.sendTransform(t);
  const std::string local = tempPath("local.bt");
  ASSERT_TRUE(sphereTree(0.0, 0.0, 0.0, 0.06, 0.01).writeBinary(local));
  r = load(local, "scanner");
  ASSERT_TRUE(r.success) << r.message;
  ASSERT_TRUE(
      status_.waitFor(10.0, [&](const Status& m) { return m.obstacle_field_source == local; }));

  // An empty path removes the field.
  r = load("");
  ASSERT_TRUE(r.success) << r.message;
  ASSERT_TRUE(status_.waitFor(10.0, [](const Status& m) { return !m.obstacle_field_loaded; }));
  std::remove(good.c_str());
  std::remove(garbage.c_str());
  std::remove(local.c_str());
}

TEST_F(NodeObstacles, TheSceneMapFollowsItsParameters) {
  ros::ServiceClient set =
      nh_.serviceClient<wet_curly_hair::SetParameters>("/wet_curly_hair/set_parameters");
  const std::string good = tempPath("param.bt");
  ASSERT_TRUE(sphereTree(-0.05, 0.05, -0.25, 0.05, 0.01).writeBinary(good));
  wet_curly_hair::SetParameters srv;
  srv.request.string_names = {"obstacle_map.file"};
  srv.request.string_values = {good};
  srv.request.names = {"obstacle_map.offset_m.x"};
  srv.request.values = {0.01};
  ASSERT_TRUE(wch_test::call(set, &srv));
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  std::printf("[ set      ] %s\n", srv.response.message.c_str());
  ASSERT_TRUE(
      status_.waitFor(10.0, [&](const Status& m) { return m.obstacle_field_source == good; }));
  // a bad file is refused with everything else in the request, and the field stays
  srv.request.string_values = {tempPath("missing.bt")};
  srv.request.values = {0.02};
  ASSERT_TRUE(wch_test::call(set, &srv));
  EXPECT_FALSE(srv.response.success);
  EXPECT_NE(srv.response.message.find("obstacle_map.file"), std::string::npos)
      << srv.response.message;
  wet_curly_hair::GetParameters get;
  get.request.names = {"obstacle_map.file", "obstacle_map.offset_m.x"};
  ros::ServiceClient getter =
      nh_.serviceClient<wet_curly_hair::GetParameters>("/wet_curly_hair/get_parameters");
  ASSERT_TRUE(wch_test::call(getter, &get));
  EXPECT_EQ(get.response.string_values[0], good);
  EXPECT_DOUBLE_EQ(get.response.values[1], 0.01);
  EXPECT_EQ(nextStatus().obstacle_field_source, good);
  // an empty file name removes the field
  srv.request.string_values = {""};
  srv.request.names.clear();
  srv.request.values.clear();
  ASSERT_TRUE(wch_test::call(set, &srv));
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  ASSERT_TRUE(status_.waitFor(10.0, [](const Status& m) { return !m.obstacle_field_loaded; }));
  std::remove(good.c_str());
}

/// Publishes a message under the type name and MD5 octomap_server uses.
class OctomapPublisher {
 public:
  explicit OctomapPublisher(ros::NodeHandle& nh) {
    shifter_.morph("9a45536b45c5e409cd49f04bb2d9999f", "octomap_msgs/Octomap",
                   ros::message_traits::definition<OctomapCompat>(), "true");
    pub_ = shifter_.advertise(nh, "/octomap_binary", 1, true);
  }
  void publish(const OctomapCompat& m) {
    const uint32_t size = ros::serialization::serializationLength(m);
    std::vector<uint8_t> buffer(size);
    ros::serialization::OStream out(buffer.data(), size);
    ros::serialization::serialize(out, m);
    ros::serialization::IStream in(buffer.data(), size);
    shifter_.read(in);
    pub_.publish(shifter_);
  }
  uint32_t subscribers() const { return pub_.getNumSubscribers(); }

 private:
  topic_tools::ShapeShifter shifter_;
  ros::Publisher pub_;
};

TEST_F(NodeObstacles, AnOctomapTopicReachesTheNode) {
  OctomapPublisher pub(nh_);
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(20.0);
  while (pub.subscribers() == 0 && ros::WallTime::now() < end) ros::WallDuration(0.05).sleep();
  ASSERT_GT(pub.subscribers(), 0u) << "the node did not subscribe to /octomap_binary";
  const uint32_t refused0 = nextStatus().obstacle_maps_refused;

  OctomapCompat m;
  m.header.stamp = ros::Time::now();
  m.header.frame_id = "world";
  m.binary = true;
  m.id = "OcTree";
  m.resolution = 0.01;
  std::stringstream bits;
  ASSERT_TRUE(sphereTree(0.0, -0.1, -0.2, 0.05, 0.01).writeBinaryData(bits));
  const std::string data = bits.str();
  m.data.assign(data.begin(), data.end());
  pub.publish(m);
  Status s;
  ASSERT_TRUE(status_.waitFor(
      20.0, [](const Status& x) { return x.obstacle_field_source == "topic /octomap_binary"; }, &s))
      << "the map published as octomap_msgs/Octomap did not reach the node";
  EXPECT_TRUE(s.obstacle_field_loaded);

  OctomapCompat bad = m;  // truncated payload
  bad.data.resize(bad.data.size() / 3);
  pub.publish(bad);
  ASSERT_TRUE(status_.waitFor(
      10.0, [&](const Status& x) { return x.obstacle_maps_refused == refused0 + 1; }, &s));
  EXPECT_TRUE(s.obstacle_field_loaded) << "a bad map removed the previous field";
  std::printf("[ refused  ] truncated map: %s\n", s.obstacle_last_error.c_str());
  OctomapCompat no_frame = m;
  no_frame.header.frame_id = "";
  pub.publish(no_frame);
  ASSERT_TRUE(status_.waitFor(
      10.0, [&](const Status& x) { return x.obstacle_maps_refused == refused0 + 2; }, &s));
  EXPECT_NE(s.obstacle_last_error.find("frame_id"), std::string::npos) << s.obstacle_last_error;
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_obstacles");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
