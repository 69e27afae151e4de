// rostest (lockstep_clock.test): wet_curly_hair_lockstep_clock with two strands topics waits
// for the slower one. The test plays both heads: it publishes strands stamps itself.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include "ros_test_helpers.h"

using wch_test::Latest;
using wet_curly_hair::Strands;

namespace {

const double kStep = 0.005, kLead = 0.05;  // lockstep_clock.test's ~step_s and ~max_lead_s

class LockstepClock : public testing::Test {
 protected:
  LockstepClock()
      : clock_(nh_, "/clock"),
        a_(nh_.advertise<Strands>("/head_a/wet_curly_hair/strands", 10)),
        b_(nh_.advertise<Strands>("/head_b/wet_curly_hair/strands", 10)) {}

  double now() {
    rosgraph_msgs::Clock c;
    EXPECT_TRUE(clock_.next(10.0, &c)) << "no /clock within 10 s";
    return c.clock.toSec();
  }
  static void send(ros::Publisher& p, double stamp_s) {
    Strands m;
    m.header.stamp = ros::Time(stamp_s);
    p.publish(m);
  }
  /// For wait_s of wall time: head_a follows /clock (a frame at every clock value), head_b
  /// stays where it is. Returns the largest clock seen.
  double followWithA(double wait_s) {
    double largest = 0.0;
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(wait_s);
    while (ros::WallTime::now() < end) {
      const double t = now();
      largest = std::max(largest, t);
      send(a_, t);
    }
    return largest;
  }

  ros::NodeHandle nh_;
  Latest<rosgraph_msgs::Clock> clock_;
  ros::Publisher a_, b_;
};

TEST_F(LockstepClock, WaitsForTheSlowerOfTwoHeads) {
  // The clock subscribes to both topics.
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(20.0);
  while ((a_.getNumSubscribers() == 0 || b_.getNumSubscribers() == 0) && ros::WallTime::now() < end)
    ros::WallDuration(0.01).sleep();
  ASSERT_GT(a_.getNumSubscribers(), 0u);
  ASSERT_GT(b_.getNumSubscribers(), 0u);
  // Before any frame, time runs freely (at most real time).
  const double t0 = now();
  ros::WallDuration(0.5).sleep();
  ASSERT_GT(now(), t0 + 0.1) << "the clock does not run before the first frame";

  // Both heads report a frame at T; then head_a keeps up and head_b stalls for 1.5 s of wall
  // time: the clock stops at the first value past T + max_lead, at most T + max_lead + step.
  const double t_b = now();
  send(b_, t_b);
  send(a_, t_b);
  const double largest = followWithA(1.5);
  EXPECT_LE(largest, t_b + kLead + kStep + 1e-6)
      << "the clock ran " << largest - t_b << " s past head_b's newest frame";

  // head_b catches up by 1 s: the clock moves on with it (1.05 s of ROS time at max_rate 1 takes
  // 1.05 s of wall time and more: every step also waits for the scheduler), and stops again
  // past that frame.
  send(b_, t_b + 1.0);
  const double after = followWithA(6.0);
  EXPECT_GT(after, t_b + 1.0) << "the clock did not follow head_b";
  EXPECT_LE(after, t_b + 1.0 + kLead + kStep + 1e-6);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_lockstep_clock");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
