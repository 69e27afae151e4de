// rostest (two_heads.test): two nodes of launch_notes/two_heads.launch in one graph, in the
// namespaces head_a and head_b. Each publishes under its own namespace and follows its own head
// frame and motion; a reset of head_a leaves head_b running and head_a comes back.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <string>
#include <vector>

#include "ros_test_helpers.h"

using wch_test::Latest;
using wet_curly_hair::Status;
using wet_curly_hair::Strands;

namespace {

/// What two_heads.launch and two_heads.test set up.
struct Head {
  std::string ns;          // e.g. /head_a
  std::string head_frame;  // its tf2 frame
  double base_y_m;         // y of the head centre (the motion's base), m
  int axis;                // the motion's rotation axis: 0 x, 1 y, 2 z (shake: z, nod: y)
  std::string node() const { return ns + "/wet_curly_hair"; }
};
const Head kA{"/head_a", "head_a/head", 0.3, 2};
const Head kB{"/head_b", "head_b/head", -0.3, 1};
const double kRate = 30.0;  // two_heads.test's publish_rate

/// Every message of one strands topic, with its wall-clock arrival time.
class Recorder {
 public:
  struct Arrival {
    double wall_s;
    Strands::ConstPtr msg;
  };
  Recorder(ros::NodeHandle& nh, const std::string& topic) {
    // A queue of 10 s of frames: nothing is dropped while the test thread sleeps.
    sub_ = nh.subscribe(topic, 300, &Recorder::onMessage, this);
  }
  ~Recorder() { sub_.shutdown(); }
  std::vector<Arrival> arrivals() {
    std::lock_guard<std::mutex> lock(mutex_);
    return arrivals_;
  }

 private:
  void onMessage(const Strands::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    arrivals_.push_back({ros::WallTime::now().toSec(), m});
  }
  ros::Subscriber sub_;
  std::mutex mutex_;
  std::vector<Arrival> arrivals_;
};

bool running(const Strands& m) { return m.reset_count >= 1 && m.step > 2; }

double q(const geometry_msgs::Quaternion& r, int axis) {
  return axis == 0 ? r.x : axis == 1 ? r.y : r.z;
}

/// Checks one head's messages of a few seconds against its frame, place and motion.
void checkHead(const Head& h, const std::vector<Recorder::Arrival>& arrivals, tf2_ros::Buffer& tf) {
  SCOPED_TRACE(h.ns);
  std::string head_frame, world_frame;
  ASSERT_TRUE(ros::param::get(h.node() + "/head_frame", head_frame));
  ASSERT_TRUE(ros::param::get(h.node() + "/world_frame", world_frame));
  EXPECT_EQ(head_frame, h.head_frame);
  EXPECT_EQ(world_frame, "world");
  ASSERT_GT(arrivals.size(), 30u) << "fewer than 30 frames in 3 s at " << kRate << " Hz";
  double largest_turn = 0.0;
  int tf_exact = 0;
  for (const auto& a : arrivals) {
    const Strands& m = *a.msg;
    ASSERT_EQ(wch_test::strandsProblem(m), "");
    EXPECT_EQ(m.header.frame_id, "world");
    EXPECT_EQ(m.strand_offsets.back(), 24u * 16u);  // two_heads.test's groom
    // Its own head: the motion is a pure rotation about the head's base, at y = base_y_m.
    const auto& p = m.head_pose.position;
    ASSERT_NEAR(p.x, 0.0, 1e-9);
    ASSERT_NEAR(p.y, h.base_y_m, 1e-9) << "the node follows another head";
    ASSERT_NEAR(p.z, 0.0, 1e-9);
    // Its own motion: a rotation about one axis only (the other two quaternion parts vanish).
    for (int k = 0; k < 3; ++k) {
      if (k == h.axis) continue;
      ASSERT_NEAR(q(m.head_pose.orientation, k), 0.0, 1e-9) << "axis " << k;
    }
    largest_turn = std::max(largest_turn, std::abs(q(m.head_pose.orientation, h.axis)));
    // The hair's centroid on its own head's side of the mid-plane y = 0.
    double y = 0.0;
    for (size_t i = 1; i < m.positions.size(); i += 3) y += m.positions[i];
    y /= m.positions.size() / 3;
    ASSERT_GT(y * h.base_y_m, 0.0) << "hair centroid y " << y << " on the other head's side";
    // The pose is the one of its own frame over tf2 (exactly, unless that frame's lookup fell
    // back to the previous pose: the node counts those in its status).
    std::string err;
    if (tf.canTransform("world", h.head_frame, m.header.stamp, ros::Duration(1.0), &err)) {
      const auto t = tf.lookupTransform("world", h.head_frame, m.header.stamp);
      EXPECT_NEAR(t.transform.translation.y, p.y, 1e-9);
      if (std::abs(t.transform.rotation.x - m.head_pose.orientation.x) < 1e-9 &&
          std::abs(t.transform.rotation.y - m.head_pose.orientation.y) < 1e-9 &&
          std::abs(t.transform.rotation.z - m.head_pose.orientation.z) < 1e-9)
        ++tf_exact;
    }
  }
  // Shake 0.6 rad at 0.3 Hz and nod 0.3 rad at 0.5 Hz: over 3 s (more than half a period of
  // either) each reaches its amplitude, |q| = sin(amplitude / 2) = 0.30 and 0.15.
  EXPECT_GT(largest_turn, 0.1) << "the head did not turn about its motion's axis";
  EXPECT_GT(tf_exact, 0) << "no frame carried the pose of " << h.head_frame << " over tf2";
  std::printf("[ %s ] %zu frames, largest |q| %.3f, %d of them exactly the tf2 pose\n",
              h.ns.c_str(), arrivals.size(), largest_turn, tf_exact);
}

TEST(TwoHeads, EachPublishesUnderItsNamespaceOnItsOwnFrameAndMotion) {
  ros::NodeHandle nh;
  tf2_ros::Buffer tf;
  tf2_ros::TransformListener listener(tf);
  Latest<Strands> a(nh, kA.node() + "/strands"), b(nh, kB.node() + "/strands");
  ASSERT_TRUE(a.waitFor(60.0, running)) << "head_a: no running strands within 60 s";
  ASSERT_TRUE(b.waitFor(60.0, running)) << "head_b: no running strands within 60 s";
  Recorder ra(nh, kA.node() + "/strands"), rb(nh, kB.node() + "/strands");
  ros::WallDuration(3.0).sleep();
  const auto arrivals_a = ra.arrivals(), arrivals_b = rb.arrivals();
  checkHead(kA, arrivals_a, tf);
  checkHead(kB, arrivals_b, tf);
  // Two simulations, not one seen twice: the particles differ.
  EXPECT_NE(arrivals_a.back().msg->positions, arrivals_b.back().msg->positions);
  // Nothing of either node outside its namespace (the node's own topics, private names).
  ros::master::V_TopicInfo topics;
  ASSERT_TRUE(ros::master::getTopics(topics));
  for (const auto& t : topics)
    EXPECT_TRUE(t.name.rfind("/head_a/", 0) == 0 || t.name.rfind("/head_b/", 0) == 0 ||
                t.name == "/tf" || t.name == "/tf_static" || t.name == "/rosout" ||
                t.name == "/rosout_agg" || t.name == "/octomap_binary")
        << "topic outside the heads' namespaces: " << t.name;
}

TEST(TwoHeads, ResetOfOneLeavesTheOtherRunning) {
  ros::NodeHandle nh;
  Latest<Strands> a(nh, kA.node() + "/strands"), b(nh, kB.node() + "/strands");
  Latest<Status> status_b(nh, kB.node() + "/status");
  Strands a0, b0;
  ASSERT_TRUE(a.waitFor(60.0, running, &a0)) << "head_a: no running strands within 60 s";
  ASSERT_TRUE(b.waitFor(60.0, running, &b0)) << "head_b: no running strands within 60 s";
  Recorder ra(nh, kA.node() + "/strands"), rb(nh, kB.node() + "/strands");
  Status s0;
  ASSERT_TRUE(status_b.next(10.0, &s0));
  ros::WallDuration(2.0).sleep();  // head_b's frames before the reset

  ros::ServiceClient reset = nh.serviceClient<std_srvs::Trigger>(kA.node() + "/reset");
  std_srvs::Trigger srv;
  ASSERT_TRUE(wch_test::call(reset, &srv));
  ASSERT_TRUE(srv.response.success) << srv.response.message;

  // head_a comes back: frames of the next reset, counted again from 1, running for 1 s.
  EXPECT_TRUE(a.waitFor(20.0, [&](const Strands& m) {
    return m.reset_count == a0.reset_count + 1 && m.step >= kRate;
  })) << "head_a did not run for 1 s after its reset within 20 s";
  Status s1;
  ASSERT_TRUE(status_b.next(10.0, &s1));
  const auto arrivals_a = ra.arrivals(), arrivals_b = rb.arrivals();

  uint64_t first_after = 0;
  for (const auto& r : arrivals_a) {
    EXPECT_GE(r.msg->reset_count, a0.reset_count);
    EXPECT_LE(r.msg->reset_count, a0.reset_count + 1);
    if (r.msg->reset_count == a0.reset_count + 1 && first_after == 0) first_after = r.msg->step;
  }
  EXPECT_EQ(first_after, 1u) << "head_a's first frame after the reset";

  // head_b: every frame in order on its grid (one frame apart in step and stamp), never reset,
  // none skipped. The node simulates at most ~max_catchup_frames frames in one timer tick and
  // skips the rest, so without skipped frames it has never been silent for longer than
  // (max_catchup_frames + 1) frames: the largest gap between two arrivals allowed here.
  int max_catchup = 0;
  ASSERT_TRUE(ros::param::get(kB.node() + "/max_catchup_frames", max_catchup));
  const double bound_s = (max_catchup + 1) / kRate;
  const int64_t frame_ns = std::llround(1e9 / kRate);
  // The window: 2 s before the reset and at least 1 s after it.
  ASSERT_GT(arrivals_b.size(), 2 * kRate) << "head_b: fewer frames than in 2 s";
  double largest_gap = 0.0;
  for (size_t k = 0; k < arrivals_b.size(); ++k) {
    const Strands& m = *arrivals_b[k].msg;
    ASSERT_EQ(m.reset_count, b0.reset_count) << "head_b was reset (frame " << k << ")";
    if (k == 0) continue;
    const Strands& p = *arrivals_b[k - 1].msg;
    ASSERT_EQ(m.step, p.step + 1) << "head_b lost frames at " << k;
    ASSERT_EQ(static_cast<int64_t>(m.header.stamp.toNSec() - p.header.stamp.toNSec()), frame_ns);
    largest_gap = std::max(largest_gap, arrivals_b[k].wall_s - arrivals_b[k - 1].wall_s);
  }
  EXPECT_LT(largest_gap, bound_s) << "head_b silent for " << largest_gap << " s";
  EXPECT_EQ(s1.skipped_frames, s0.skipped_frames) << "head_b skipped frames";
  EXPECT_GT(arrivals_b.back().wall_s, arrivals_a.back().wall_s - bound_s)
      << "head_b stopped before head_a came back";
  std::printf(
      "[ head_b ] %zu frames across the reset of head_a, largest gap %.3f s (bound %.3f s)\n",
      arrivals_b.size(), largest_gap, bound_s);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_two_heads");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
