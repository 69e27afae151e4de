// rostest (bag_replay.test): the node's output on a replayed bag against the expected bag, and
// run against run.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <cmath>
#include <map>
#include <mutex>

#include "wet_curly_hair/Status.h"
#include "wet_curly_hair/Strands.h"

using wet_curly_hair::Status;
using wet_curly_hair::Strands;

namespace {

/// Strands messages of one pass of the bag, from the frame the head pose appeared (step 0).
using Pass = std::map<uint64_t, Strands::ConstPtr>;

class Recorder {
 public:
  explicit Recorder(ros::NodeHandle& nh)
      : sub_(nh.subscribe("/wet_curly_hair/strands", 1000, &Recorder::onStrands, this)),
        status_sub_(nh.subscribe("/wet_curly_hair/status", 10, &Recorder::onStatus, this)) {}
  ~Recorder() {
    sub_.shutdown();
    status_sub_.shutdown();
  }
  /// Waits (wall clock) until `passes` complete passes were seen.
  bool waitPasses(size_t passes, double timeout_s) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::ok() && ros::WallTime::now() < end) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (passes_.size() > passes) return true;  // the one after them has started
      }
      ros::WallDuration(0.01).sleep();
    }
    return false;
  }
  std::vector<Pass> passes() {
    std::lock_guard<std::mutex> lock(mutex_);
    return passes_;
  }
  Status status() {
    std::lock_guard<std::mutex> lock(mutex_);
    return status_;
  }

 private:
  void onStrands(const Strands::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (m->step == 0) passes_.emplace_back();  // the head pose appeared: a pass starts
    if (!passes_.empty()) passes_.back()[m->header.stamp.toNSec()] = m;
  }
  void onStatus(const Status::ConstPtr& s) {
    std::lock_guard<std::mutex> lock(mutex_);
    status_ = *s;
  }
  // Declared before the subscribers: members are built in this order and destroyed in reverse,
  // so no callback (from the spinner thread) can see an unbuilt or destroyed mutex or pass list.
  std::mutex mutex_;
  std::vector<Pass> passes_;
  Status status_;
  ros::Subscriber sub_, status_sub_;
};

double maxDifference(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return INFINITY;
  double d = 0.0;
  for (size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(double(a[i]) - double(b[i])));
  return d;
}

TEST(BagReplay, OutputMatchesTheExpectedBagAndRepeatsExactly) {
  ros::NodeHandle nh, pnh("~");
  std::string expected_path;
  double tolerance = 1e-5;
  ASSERT_TRUE(pnh.getParam("expected_bag", expected_path));
  pnh.getParam("tolerance", tolerance);
  Recorder recorder(nh);
  ASSERT_TRUE(recorder.waitPasses(2, 90.0)) << "did not see two passes of the bag within 90 s";
  const std::vector<Pass> passes = recorder.passes();

  rosbag::Bag bag(expected_path, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery("/wet_curly_hair/strands"));
  size_t compared = 0;
  double worst_pos = 0.0, worst_wet = 0.0, worst_sat = 0.0;
  for (const rosbag::MessageInstance& mi : view) {
    const Strands::ConstPtr e = mi.instantiate<Strands>();
    ASSERT_TRUE(e);
    for (size_t p = 0; p < 2; ++p) {
      auto it = passes[p].find(e->header.stamp.toNSec());
      ASSERT_NE(it, passes[p].end())
          << "pass " << p << ": no frame at t = " << e->header.stamp << " (expected step "
          << e->step << "); frames skipped: " << recorder.status().skipped_frames;
      const Strands& m = *it->second;
      ASSERT_EQ(m.step, e->step) << "t = " << e->header.stamp;
      ASSERT_EQ(m.strand_offsets, e->strand_offsets);
      const double dp = maxDifference(m.positions, e->positions);
      const double dw = maxDifference(m.wet_positions, e->wet_positions);
      const double ds = maxDifference(m.saturation, e->saturation);
      EXPECT_LE(dp, tolerance) << "pass " << p << ", step " << e->step << ": positions differ";
      EXPECT_LE(dw, tolerance) << "pass " << p << ", step " << e->step << ": wet_positions differ";
      EXPECT_LE(ds, tolerance) << "pass " << p << ", step " << e->step << ": saturation differs";
      worst_pos = std::max(worst_pos, dp);
      worst_wet = std::max(worst_wet, dw);
      worst_sat = std::max(worst_sat, ds);
      ++compared;
    }
  }
  EXPECT_GT(compared, 20u);
  std::printf(
      "[ replay   ] %zu frames compared with the expected bag: largest difference "
      "positions %.3g m, wet_positions %.3g m, saturation %.3g (tolerance %.3g)\n",
      compared, worst_pos, worst_wet, worst_sat, tolerance);

  // Run against run: every frame both passes have in common is bit-identical.
  size_t common = 0;
  for (const auto& [stamp, a] : passes[0]) {
    auto it = passes[1].find(stamp);
    if (it == passes[1].end()) continue;
    const Strands& b = *it->second;
    ASSERT_EQ(a->step, b.step);
    ASSERT_EQ(a->positions, b.positions) << "pass 1 differs from pass 0 at step " << a->step;
    ASSERT_EQ(a->wet_positions, b.wet_positions) << "at step " << a->step;
    ASSERT_EQ(a->saturation, b.saturation) << "at step " << a->step;
    ++common;
  }
  EXPECT_GT(common, 100u);
  const Status s = recorder.status();
  EXPECT_GE(s.time_jumps_back, 1u);
  EXPECT_EQ(s.skipped_frames, 0u);
  std::printf("[ replay   ] %zu frames identical between the two passes; time jumps back %u\n",
              common, s.time_jumps_back);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_bag_replay");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
