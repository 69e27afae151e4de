// rostest (no_tf.test): the node without a head transform, then with one, then without again.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <thread>

#include "ros_test_helpers.h"
#include "wet_curly_hair/SetSaturation.h"

using wch_test::Latest;
using wet_curly_hair::Status;
using wet_curly_hair::Strands;

namespace {

TEST(NodeWithoutTf, KeepsRunningReportsItAndPicksThePoseUp) {
  ros::NodeHandle nh;
  Latest<Status> status(nh, "/wet_curly_hair/status");
  Latest<Strands> strands(nh, "/wet_curly_hair/strands");

  // 1. No transform at all: still stepping and publishing, the status says why.
  Status s;
  ASSERT_TRUE(status.waitFor(
      30.0, [](const Status& m) { return m.step > 10; }, &s))
      << "the node does not run without a head transform";
  EXPECT_FALSE(s.head_pose_ok);
  EXPECT_FALSE(s.head_pose_ever);
  EXPECT_LT(s.head_pose_age_s, 0.0);
  EXPECT_GT(s.tf_fallbacks, 0u);
  EXPECT_NE(s.tf_error, "");
  std::printf("[ no tf    ] tf_error: %s\n", s.tf_error.c_str());
  Strands before;
  ASSERT_TRUE(strands.next(10.0, &before));
  EXPECT_EQ(wch_test::strandsProblem(before), "");
  EXPECT_EQ(before.header.frame_id, "map");
  const uint32_t resets_before = before.reset_count;
  // A saturation set before the head exists must survive the hair being placed on it.
  wet_curly_hair::SetSaturation sat;
  sat.request.strands = {0};
  sat.request.root_value = 0.25f;
  sat.request.tip_value = 0.75f;
  ASSERT_TRUE(ros::service::call("/wet_curly_hair/set_saturation", sat));
  ASSERT_TRUE(sat.response.success) << sat.response.message;
  const uint32_t per_strand = before.strand_offsets[1] - before.strand_offsets[0];

  // 2. The head appears at (0.5, -0.2, 1.4), turned 90 degrees about z.
  std::atomic<bool> broadcasting{true};
  std::thread broadcaster([&] {
    tf2_ros::TransformBroadcaster br;
    ros::WallRate rate(50.0);
    while (broadcasting && ros::ok()) {
      geometry_msgs::TransformStamped t;
      t.header.stamp = ros::Time::now();
      t.header.frame_id = "map";
      t.child_frame_id = "robot_head";
      t.transform.translation.x = 0.5;
      t.transform.translation.y = -0.2;
      t.transform.translation.z = 1.4;
      t.transform.rotation.z = std::sqrt(0.5);
      t.transform.rotation.w = std::sqrt(0.5);
      br.sendTransform(t);
      rate.sleep();
    }
  });
  ASSERT_TRUE(status.waitFor(
      20.0, [](const Status& m) { return m.head_pose_ok; }, &s))
      << "the node did not pick up the head pose";
  EXPECT_TRUE(s.head_pose_ever);
  EXPECT_GE(s.head_pose_age_s, 0.0);
  EXPECT_EQ(s.tf_error, "");
  Strands after;
  ASSERT_TRUE(strands.next(10.0, &after));
  EXPECT_GT(after.reset_count, resets_before) << "the hair was not placed on the new pose";
  EXPECT_NEAR(after.saturation[0], 0.25, 1e-3) << "placing the hair undid set_saturation";
  EXPECT_NEAR(after.saturation[per_strand - 1], 0.75, 1e-3) << "placing the hair undid it";
  EXPECT_NEAR(after.head_pose.position.x, 0.5, 1e-9);
  EXPECT_NEAR(after.head_pose.position.y, -0.2, 1e-9);
  EXPECT_NEAR(after.head_pose.position.z, 1.4, 1e-9);
  EXPECT_NEAR(after.head_pose.orientation.z, std::sqrt(0.5), 1e-9);
  // every particle within reach of the new head position (strands are < 0.3 m from the head)
  const size_t n = after.saturation.size();
  for (size_t i = 0; i < n; ++i) {
    const double dx = after.positions[3 * i] - 0.5, dy = after.positions[3 * i + 1] + 0.2,
                 dz = after.positions[3 * i + 2] - 1.4;
    ASSERT_LT(std::sqrt(dx * dx + dy * dy + dz * dz), 0.5) << "particle " << i;
  }

  // 3. The transform stops: fallback to the last pose, counted; the node keeps running.
  broadcasting = false;
  broadcaster.join();
  ASSERT_TRUE(status.waitFor(
      20.0, [](const Status& m) { return !m.head_pose_ok; }, &s))
      << "the status still claims a fresh pose after the transform stopped";
  const uint64_t fallbacks = s.tf_fallbacks;
  EXPECT_TRUE(s.head_pose_ever);
  ASSERT_TRUE(status.waitFor(
      10.0, [&](const Status& m) { return m.tf_fallbacks > fallbacks + 5; }, &s));
  EXPECT_GT(s.head_pose_age_s, 0.0);
  Strands last;
  ASSERT_TRUE(strands.next(10.0, &last));
  EXPECT_EQ(last.reset_count, after.reset_count) << "losing the pose must not reset the hair";
  EXPECT_NEAR(last.head_pose.position.x, 0.5, 1e-9) << "fallback is the last pose";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_no_tf");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
