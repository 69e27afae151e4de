// rostest (nodelet.test): wet_curly_hair/WetCurlyHairNodelet and wet_curly_hair/StrandsSinkNodelet
// in one nodelet manager. The node runs as a nodelet (status, strands), the sink in its manager
// takes its frames (~received: each frame's serialized size), and a subscriber outside the
// manager receives the same frames, of that size.
#include <gtest/gtest.h>
#include <nodelet/NodeletList.h>
#include <ros/ros.h>
#include <ros/serialization.h>
#include <std_msgs/UInt64.h>

#include <algorithm>
#include <string>

#include "ros_test_helpers.h"

using wch_test::Latest;
using wet_curly_hair::Status;
using wet_curly_hair::Strands;

namespace {

constexpr uint32_t kParticles = 24 * 16;  // nodelet.test's groom

TEST(NodeNodelet, RunsInAManagerAndItsFramesReachTheSinkAndOutsideSubscribers) {
  ros::NodeHandle nh;
  Latest<Status> status(nh, "/wet_curly_hair/status");
  Latest<Strands> strands(nh, "/wet_curly_hair/strands");
  Latest<std_msgs::UInt64> received(nh, "/strands_sink/received");
  Status st;
  ASSERT_TRUE(status.waitFor(
      60.0, [](const Status& s) { return s.step > 0; }, &st))
      << "no status from the node nodelet";
  EXPECT_EQ(st.particles, kParticles);
  Strands frame;
  ASSERT_TRUE(strands.next(20.0, &frame)) << "no strands outside the manager";
  EXPECT_EQ(wch_test::strandsProblem(frame), "");
  EXPECT_EQ(frame.strand_offsets.back(), kParticles);
  // The sink reports the size each frame has serialized: the same groom, the same size as the
  // frame that came over TCPROS.
  const uint64_t size = ros::serialization::serializationLength(frame);
  std_msgs::UInt64 got;
  ASSERT_TRUE(received.next(20.0, &got)) << "the sink nodelet took no frame";
  EXPECT_EQ(got.data, size);
  // Frames keep coming to both, at the publish rate (30 Hz): 10 more of each within 10 s.
  const uint64_t sink0 = received.count(), outside0 = strands.count();
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(10.0);
  while (ros::WallTime::now() < end &&
         (received.count() < sink0 + 10 || strands.count() < outside0 + 10))
    ros::WallDuration(0.05).sleep();
  EXPECT_GE(received.count(), sink0 + 10);
  EXPECT_GE(strands.count(), outside0 + 10);
}

TEST(NodeNodelet, ANodeletThatRefusesItsParametersLeavesTheManagerRunning) {
  // nodelet.test loads refused_hair (groom/strands -5) into the same manager: its load fails
  // (the manager lists it no more), it advertises nothing, and the first node keeps publishing.
  ros::NodeHandle nh;
  Latest<Status> status(nh, "/wet_curly_hair/status");
  ASSERT_TRUE(status.next(60.0, nullptr)) << "no status from the node nodelet";
  ros::WallDuration(3.0).sleep();  // refused_hair's load has run (the loader starts at once)
  nodelet::NodeletList list;
  ASSERT_TRUE(ros::service::call("/wet_curly_hair_manager/list", list));
  EXPECT_NE(
      std::find(list.response.nodelets.begin(), list.response.nodelets.end(), "/wet_curly_hair"),
      list.response.nodelets.end());
  EXPECT_EQ(
      std::find(list.response.nodelets.begin(), list.response.nodelets.end(), "/refused_hair"),
      list.response.nodelets.end())
      << "the refused nodelet stayed loaded";
  ros::master::V_TopicInfo topics;
  ASSERT_TRUE(ros::master::getTopics(topics));
  for (const ros::master::TopicInfo& t : topics)
    EXPECT_NE(t.name.rfind("/refused_hair/", 0), 0u) << "the refused nodelet advertises " << t.name;
  Status st;
  EXPECT_TRUE(status.next(10.0, &st)) << "the node stopped when the other nodelet was refused";
}

TEST(NodeNodelet, FramesAConsumerKeepsNeverChangeUnderIt) {
  // The sink keeps its last 8 frames (nodelet.test), twice what the node keeps to fill again:
  // after 2 s of frames, every kept frame still holds its step and positions.
  ros::NodeHandle nh;
  Latest<std_msgs::UInt64> changed(nh, "/strands_sink/changed");
  std_msgs::UInt64 got;
  ASSERT_TRUE(changed.waitFor(
      60.0, [](const std_msgs::UInt64&) { return true; }, &got))
      << "no ~changed from the sink";
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(2.0);
  uint64_t worst = got.data;
  while (ros::WallTime::now() < end) {
    if (changed.next(1.0, &got)) worst = std::max<uint64_t>(worst, got.data);
  }
  EXPECT_GE(changed.count(), 20u) << "fewer frames than 2 s at 30 Hz";
  EXPECT_EQ(worst, 0u) << "the node wrote into a frame the sink still held";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_nodelet");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
