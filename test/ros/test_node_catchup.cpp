// rostest (catchup.test): catch-up frame skipping. This test drives /clock: real-time pace, then
// one jump of kJumpFrames frames. Every frame of ROS time is either stepped or skipped and
// counted; the jump's tick steps ~max_catchup_frames (10) and skips the rest.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include <atomic>
#include <thread>

#include "ros_test_helpers.h"

using wch_test::Latest;

namespace {

constexpr int64_t kFrameNs = 50000000;  // ~publish_rate 20
constexpr int64_t kMaxCatchup = 10;     // ~max_catchup_frames
constexpr int64_t kJumpFrames = 100;

/// Publishes /clock every 10 ms of wall time, advancing 10 ms (real-time pace) plus any jump
/// requested.
class ClockDriver {
 public:
  explicit ClockDriver(ros::NodeHandle& nh)
      : pub_(nh.advertise<rosgraph_msgs::Clock>("/clock", 10)), thread_([this] { run(); }) {}
  ~ClockDriver() {
    stop_ = true;
    thread_.join();
  }
  void jump(int64_t ns) { jump_ns_ += ns; }

 private:
  void run() {
    int64_t now_ns = 100 * 1000000000LL;
    while (!stop_ && ros::ok()) {
      now_ns += 10000000 + jump_ns_.exchange(0);
      rosgraph_msgs::Clock c;
      c.clock.fromNSec(static_cast<uint64_t>(now_ns));
      pub_.publish(c);
      ros::WallDuration(0.01).sleep();
    }
  }
  ros::Publisher pub_;
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> jump_ns_{0};
  std::thread thread_;
};

TEST(NodeCatchup, FramesBeyondTheCatchupLimitAreSkippedAndCounted) {
  ros::NodeHandle nh;
  Latest<wet_curly_hair::Status> status(nh, "/wet_curly_hair/status");
  ClockDriver clock(nh);
  wet_curly_hair::Status before, after;
  ASSERT_TRUE(status.waitFor(
      30.0, [](const wet_curly_hair::Status& m) { return m.step > 10; }, &before))
      << "no status with step > 10 within 30 s";
  clock.jump(kJumpFrames * kFrameNs);
  ASSERT_TRUE(status.waitFor(
      10.0,
      [&](const wet_curly_hair::Status& m) {
        return m.skipped_frames >= before.skipped_frames + kJumpFrames - kMaxCatchup;
      },
      &after))
      << "no status counting the skipped frames within 10 s of the jump";
  EXPECT_EQ(after.reset_count, before.reset_count) << "a forward jump must not reset the hair";
  EXPECT_EQ(after.time_jumps_back, before.time_jumps_back);
  const int64_t skipped = static_cast<int64_t>(after.skipped_frames - before.skipped_frames);
  const int64_t stepped = static_cast<int64_t>(after.step - before.step);
  const int64_t elapsed =
      static_cast<int64_t>(after.header.stamp.toNSec() - before.header.stamp.toNSec());
  // The stamps lie on the frame grid; every frame between them was stepped or skipped.
  EXPECT_EQ(elapsed % kFrameNs, 0);
  EXPECT_EQ(stepped + skipped, elapsed / kFrameNs);
  // The jump alone forces kJumpFrames - kMaxCatchup skips; at real-time pace nothing else does
  // (the few frames pending at the jump are stepped in its tick).
  EXPECT_GE(skipped, kJumpFrames - kMaxCatchup);
  EXPECT_LE(skipped, kJumpFrames);
  EXPECT_GE(stepped, kMaxCatchup);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_catchup");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
