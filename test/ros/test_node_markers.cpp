// rostest (markers.test): ~markers only while subscribed. Without a subscriber the node publishes
// no MarkerArray (~status markers_published stays 0 while frames are stepped); with one it
// publishes one per tick and the subscriber receives them; after the subscriber leaves the count
// stops again.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <visualization_msgs/MarkerArray.h>

#include <memory>

#include "ros_test_helpers.h"

using wch_test::Latest;

namespace {

TEST(NodeMarkers, PublishedOnlyWhileSubscribed) {
  ros::NodeHandle nh;
  Latest<wet_curly_hair::Status> status(nh, "/wet_curly_hair/status");
  wet_curly_hair::Status s;
  // Unsubscribed: 20 ticks (2/3 s at 30 Hz), none published.
  ASSERT_TRUE(status.waitFor(
      30.0, [](const wet_curly_hair::Status& m) { return m.step > 5; }, &s))
      << "no status with step > 5 within 30 s";
  const uint64_t first_step = s.step;
  ASSERT_TRUE(status.waitFor(
      10.0, [&](const wet_curly_hair::Status& m) { return m.step >= first_step + 20; }, &s));
  EXPECT_EQ(s.markers_published, 0u) << "markers published with no subscriber";
  // Subscribed: received, and counted.
  auto markers =
      std::make_unique<Latest<visualization_msgs::MarkerArray>>(nh, "/wet_curly_hair/markers");
  visualization_msgs::MarkerArray m;
  ASSERT_TRUE(markers->next(10.0, &m)) << "no markers within 10 s of subscribing";
  // The hair is one LINE_LIST beside the head's shapes (and any obstacles).
  const visualization_msgs::Marker* hair = nullptr;
  for (const visualization_msgs::Marker& k : m.markers)
    if (k.ns == "wet_curly_hair/strands") hair = &k;
  ASSERT_NE(hair, nullptr) << "no marker in namespace wet_curly_hair/strands";
  EXPECT_EQ(hair->points.size(), 2u * 8u * 9u);  // 8 strands of 9 edges
  ASSERT_TRUE(markers->next(5.0, &m));
  ASSERT_TRUE(status.next(5.0, &s));
  EXPECT_GE(s.markers_published, 2u);
  // Unsubscribed again: once the node has seen the subscriber go (a few ticks), the count holds.
  markers.reset();
  ros::WallDuration(1.0).sleep();
  ASSERT_TRUE(status.next(5.0, &s));
  const uint64_t after_leaving = s.markers_published;
  const uint64_t step_after_leaving = s.step;
  ASSERT_TRUE(status.waitFor(
      10.0, [&](const wet_curly_hair::Status& x) { return x.step >= step_after_leaving + 20; },
      &s));
  EXPECT_EQ(s.markers_published, after_leaving) << "markers published after the subscriber left";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_markers");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
