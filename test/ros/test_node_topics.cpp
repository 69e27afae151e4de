// rostest (topics.test): the strands, status and markers topics of a running node.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>

#include "ros_test_helpers.h"

using wch_test::Latest;

namespace {

TEST(NodeTopics, StrandsHaveConsistentSizesAndStepOnTheFrameGrid) {
  ros::NodeHandle nh;
  Latest<wet_curly_hair::Strands> strands(nh, "/wet_curly_hair/strands");
  wet_curly_hair::Strands a, b;
  // After the head pose is taken (which resets the hair once), frames follow one another.
  ASSERT_TRUE(strands.waitFor(
      30.0, [](const wet_curly_hair::Strands& m) { return m.reset_count >= 1 && m.step > 2; }, &a))
      << "no strands message with step > 2 after the head pose was taken, within 30 s";
  ASSERT_TRUE(strands.next(5.0, &b));
  ASSERT_EQ(a.reset_count, b.reset_count) << "unexpected reset";
  for (const auto* m : {&a, &b}) {
    EXPECT_EQ(wch_test::strandsProblem(*m), "");
    EXPECT_EQ(m->strand_offsets.size(), 25u);        // ~groom/strands = 24
    EXPECT_EQ(m->strand_offsets.back(), 24u * 16u);  // ~groom/particles = 16
    EXPECT_EQ(m->guide_strands, 8u);                 // ~follow_ratio = 3: 8 guides, 16 followers
    EXPECT_EQ(m->header.frame_id, "world");
    EXPECT_EQ(m->wet_positions.size(), m->positions.size());  // cohesion on by default
    for (float x : m->positions) ASSERT_TRUE(std::isfinite(x));
  }
  // Frames lie on a grid of 1/30 s: consecutive stamps differ by whole frames, steps by as many.
  const int64_t frame_ns = std::llround(1e9 / 30.0);
  const int64_t dt = static_cast<int64_t>(b.header.stamp.toNSec() - a.header.stamp.toNSec());
  EXPECT_EQ(dt % frame_ns, 0) << "stamps off the frame grid: dt = " << dt << " ns";
  EXPECT_EQ(static_cast<int64_t>(b.step - a.step), dt / frame_ns);
  EXPECT_EQ(a.header.stamp.toNSec() % frame_ns, 0u);
}

TEST(NodeTopics, StatusReportsSizesTimingAndThePose) {
  ros::NodeHandle nh;
  Latest<wet_curly_hair::Status> status(nh, "/wet_curly_hair/status");
  // A subscriber, so that the node builds and sends ~strands (it does not for nobody).
  Latest<wet_curly_hair::Strands> strands(nh, "/wet_curly_hair/strands");
  wet_curly_hair::Status s;
  ASSERT_TRUE(status.waitFor(
      30.0, [](const wet_curly_hair::Status& m) { return m.head_pose_ok && m.step > 5; }, &s))
      << "no status with the head pose and step > 5 within 30 s";
  EXPECT_EQ(s.strands, 24);
  EXPECT_EQ(s.strands_skipped, 0u);  // a generated groom
  EXPECT_EQ(s.particles, 24 * 16);
  EXPECT_GT(s.substeps, 0);
  EXPECT_NEAR(s.frame_s, 1.0 / 30.0, 1e-9);
  EXPECT_NEAR(s.substep_s * s.substeps, s.frame_s, 1e-9);
  EXPECT_TRUE(s.head_pose_ever);
  EXPECT_GE(s.head_pose_age_s, 0.0);
  EXPECT_LT(s.head_pose_age_s, 0.5);
  EXPECT_EQ(s.tf_error, "");
  EXPECT_EQ(s.repaired_strands, 0u);
  EXPECT_EQ(s.header.frame_id, "world");
  // Every solver stage is named, timed and counted; the integrate stage ran on every
  // particle-substep of the 8 guides (~follow_ratio 3), the followers stage once per frame on
  // the 16 followers' particles.
  ASSERT_EQ(s.stage_names.size(), 14u);
  ASSERT_EQ(s.stage_times_s.size(), 14u);
  ASSERT_EQ(s.stage_particles.size(), 14u);
  EXPECT_EQ(s.stage_names[4], "integrate");
  EXPECT_EQ(s.stage_particles[4], uint64_t(s.substeps) * 8u * 16u);
  EXPECT_GT(s.stage_times_s[4], 0.0);
  EXPECT_EQ(s.stage_names[11], "hair_contact");
  EXPECT_EQ(s.stage_particles[11], 0u);  // off in this scene: nothing ran
  EXPECT_EQ(s.stage_names[12], "followers");
  EXPECT_EQ(s.stage_particles[12], 16u * 16u);
  EXPECT_EQ(s.stage_names[13], "lanes");  // the guides into their SIMD blocks, once per frame
  EXPECT_EQ(s.stage_particles[13], 8u * 16u);
  // Overhead of the node itself against the solver step, averaged over 2 s of statuses.
  double step = 0, conv = 0, pub = 0, tf = 0;
  int n = 0;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(2.0);
  while (ros::WallTime::now() < end) {
    wet_curly_hair::Status t;
    if (status.next(1.0, &t) && t.step_time_s > 0) {
      step += t.step_time_s;
      conv += t.conversion_time_s;
      pub += t.publish_time_s;
      tf += t.tf_lookup_time_s;
      ++n;
    }
  }
  ASSERT_GT(n, 0);
  EXPECT_GT(step, 0.0);
  EXPECT_GT(conv, 0.0);
  std::printf(
      "[ overhead ] %d particles: step %.3f ms, conversion %.4f ms, publish %.4f ms, tf "
      "%.4f ms per frame (node overhead %.2f%% of the step), solver RTF %.2f\n",
      s.particles, 1e3 * step / n, 1e3 * conv / n, 1e3 * pub / n, 1e3 * tf / n,
      100.0 * (conv + pub) / step, s.frame_s / (step / n));
}

TEST(NodeTopics, HairMarkerIsOneLineListColouredPerVertex) {
  ros::NodeHandle nh;
  Latest<visualization_msgs::MarkerArray> markers(nh, "/wet_curly_hair/markers");
  visualization_msgs::MarkerArray m;
  ASSERT_TRUE(markers.next(30.0, &m)) << "no markers within 30 s";
  // The head is there too (scene_markers.test checks it); the hair is one marker of its own.
  const visualization_msgs::Marker* hair = nullptr;
  for (const auto& k : m.markers)
    if (k.ns == "wet_curly_hair/strands") {
      ASSERT_EQ(hair, nullptr) << "two hair markers";
      hair = &k;
    }
  ASSERT_NE(hair, nullptr) << "no marker in namespace wet_curly_hair/strands";
  const visualization_msgs::Marker& l = *hair;
  EXPECT_EQ(l.type, visualization_msgs::Marker::LINE_LIST);
  EXPECT_EQ(l.header.frame_id, "world");
  EXPECT_EQ(l.points.size(), 2u * (24 * 16 - 24));
  EXPECT_EQ(l.colors.size(), l.points.size());
  EXPECT_GT(l.scale.x, 0.0);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_topics");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
