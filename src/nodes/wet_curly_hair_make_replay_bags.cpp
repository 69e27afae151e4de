// wet_curly_hair_make_replay_bags: writes the two bags of the bag replay test
// (test/ros/bag_replay.test; how to regenerate them: test/data/README.md).
//
//   input bag:    /tf, the head (world -> head) moving under a scripted motion, one transform
//                 on every frame boundary (multiples of the frame in ROS time), each recorded
//                 --tf-lead-s before its stamp so a replaying node always has it in time;
//                 /wet_curly_hair/saturation_changes, two scheduled saturation changes.
//   expected bag: /wet_curly_hair/strands as the node must publish it, computed here without a
//                 master by the same core calls and the same tf2 interpolation (tf2::BufferCore)
//                 the node uses, every --stride-th frame from the frame the head pose appears
//                 until 2 * --tf-lead-s before the last transform (the bag's clock ends
//                 --tf-lead-s before it, and a looping replay jumps back then).
#include <rosbag/bag.h>
#include <tf2/buffer_core.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include "wet_curly_hair/SaturationChange.h"
#include "wet_curly_hair/Strands.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/io/scene.h"
#include "wet_curly_hair/io/scene_setup.h"
#include "wet_curly_hair/ros/conversions.h"
#include "wet_curly_hair/ros/head_motion_publisher.h"

namespace {

const char* kUsage =
    "usage: wet_curly_hair_make_replay_bags --scene SCENE.yaml [--out-dir DIR] [--rate HZ]\n"
    "         [--seconds T] [--start-s T0] [--motion SPEC] [--stride N] [--tf-lead-s L]\n"
    "         [--sensitivity-m D]\n"
    "Writes DIR/replay_input.bag and DIR/replay_expected.bag (defaults: DIR ., rate 50 Hz,\n"
    "3 s of head motion from ROS time T0 = 100 s, expected frames every 5th, lead 0.2 s).\n"
    "--sensitivity-m D also reruns with the head shifted by D m and prints how far each expected\n"
    "frame moves besides the shift (to choose the replay test's tolerance).\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace wet_curly_hair;
  std::string scene_path, out_dir = ".";
  std::string motion =
      "shake:freq_hz=1.0,amplitude_rad=0.5,start_s=0.3+"
      "nod:freq_hz=0.7,amplitude_rad=0.3,start_s=0.6";
  double rate = 50.0, seconds = 3.0, start_s = 100.0, lead_s = 0.2;
  int stride = 5;
  double sensitivity_m = 0.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "%s", kUsage);
      return 2;
    }
    const std::string v = argv[++i];
    if (a == "--scene")
      scene_path = v;
    else if (a == "--out-dir")
      out_dir = v;
    else if (a == "--rate")
      rate = std::atof(v.c_str());
    else if (a == "--seconds")
      seconds = std::atof(v.c_str());
    else if (a == "--start-s")
      start_s = std::atof(v.c_str());
    else if (a == "--motion")
      motion = v;
    else if (a == "--stride")
      stride = std::atoi(v.c_str());
    else if (a == "--tf-lead-s")
      lead_s = std::atof(v.c_str());
    else if (a == "--sensitivity-m")
      sensitivity_m = std::atof(v.c_str());
    else {
      std::fprintf(stderr, "unknown option %s\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  io::SceneConfig scene;
  std::string why;
  if (scene_path.empty() || !io::loadSceneFile(scene_path, &scene, &why)) {
    std::fprintf(stderr, "wet_curly_hair_make_replay_bags: --scene: %s\n", why.c_str());
    return 2;
  }
  HeadMotionPublisherConfig head;
  if (!parseMotionChain(motion, &head.motions, &why)) {
    std::fprintf(stderr, "wet_curly_hair_make_replay_bags: %s\n", why.c_str());
    return 2;
  }
  // The node's frame grid: frame_ns = round(1e9 / rate), boundaries at multiples of it.
  const int64_t frame_ns = std::llround(1e9 / rate);
  const double frame_s = frame_ns * 1e-9;
  const int64_t t0_ns = (std::llround(start_s * 1e9) / frame_ns) * frame_ns;
  const int frames = static_cast<int>(std::llround(seconds / frame_s));
  auto stamp = [](int64_t ns) {
    ros::Time t;
    t.fromNSec(static_cast<uint64_t>(ns));
    return t;
  };

  rosbag::Bag input(out_dir + "/replay_input.bag", rosbag::bagmode::Write);
  tf2::BufferCore buffer(ros::Duration(3600.0));
  {
    // The bag starts 1 s before the first head transform with a transform of another frame:
    // when a looping replay jumps back, tf2_ros's listener clears its buffer on the first /tf
    // message it gets after seeing the new time, which may be the message after the one that
    // triggered the jump; that one must not be the first head transform.
    geometry_msgs::TransformStamped tr;
    tr.header.stamp = stamp(t0_ns - 1000000000);
    tr.header.frame_id = "world";
    tr.child_frame_id = "replay_bag_start";
    tr.transform.rotation.w = 1.0;
    tf2_msgs::TFMessage msg;
    msg.transforms.push_back(tr);
    input.write("/tf", tr.header.stamp, msg);
  }
  for (int k = 0; k <= frames; ++k) {
    const int64_t t_ns = t0_ns + k * frame_ns;
    const Pose p = headMotionChainPose(head, k * frame_s);
    geometry_msgs::TransformStamped tr;
    tr.header.stamp = stamp(t_ns);
    tr.header.frame_id = "world";
    tr.child_frame_id = "head";
    tr.transform.translation.x = p.translation.x();
    tr.transform.translation.y = p.translation.y();
    tr.transform.translation.z = p.translation.z();
    tr.transform.rotation.x = p.rotation.x();
    tr.transform.rotation.y = p.rotation.y();
    tr.transform.rotation.z = p.rotation.z();
    tr.transform.rotation.w = p.rotation.w();
    tf2_msgs::TFMessage msg;
    msg.transforms.push_back(tr);
    input.write("/tf", stamp(t_ns - std::llround(lead_s * 1e9)), msg);
    buffer.setTransform(tr, "replay");
  }
  // Two scheduled saturation changes: water rising to the tips, then a splash on some strands.
  std::multimap<int64_t, SaturationCommand> changes;
  {
    SaturationChange m;
    m.header.stamp = stamp(t0_ns + std::llround(1.0 * 1e9));
    m.root_value = 0.0f;
    m.tip_value = 1.0f;
    input.write("/wet_curly_hair/saturation_changes", stamp(m.header.stamp.toNSec() - 500000000),
                m);
    SaturationCommand c;
    saturationCommandFromMsg(m, &c, &why);
    changes.emplace(m.header.stamp.toNSec(), c);
    SaturationChange s;
    s.header.stamp = stamp(t0_ns + std::llround(1.7 * 1e9));
    s.strands = {0, 3, 5, 8, 13};
    s.root_value = 0.4f;
    s.tip_value = 0.2f;
    s.add = true;
    s.region_type = SaturationChange::REGION_SPHERE;
    s.region_frame = SaturationChange::FRAME_HEAD;
    s.region_center.z = -0.05;
    s.region_radius = 0.15;
    input.write("/wet_curly_hair/saturation_changes", stamp(s.header.stamp.toNSec() - 500000000),
                s);
    saturationCommandFromMsg(s, &c, &why);
    changes.emplace(s.header.stamp.toNSec(), c);
  }
  input.close();

  // The node's computation, frame by frame.
  HairModel model;
  if (!io::buildSceneModel(scene, &model, &why)) {
    std::fprintf(stderr, "wet_curly_hair_make_replay_bags: %s\n", why.c_str());
    return 1;
  }
  Obstacles obstacles;
  obstacles.analytic = scene.obstacles;
  const bool wet = scene.solver.cohesion.mode != "off";
  // Runs the frames; `perturb_m` shifts every head position by that much along x (sensitivity).
  auto simulate = [&](double perturb_m) {
    std::vector<Strands> out;
    std::multimap<int64_t, SaturationCommand> due = changes;
    auto lookup = [&](int64_t t_ns) {
      Pose p;
      poseFromTransform(buffer.lookupTransform("world", "head", stamp(t_ns)).transform, &p);
      p.translation.x() += perturb_m;
      return p;
    };
    Pose pose = lookup(t0_ns);
    HairState state = makeState(model, pose, Twist());
    if (scene.saturation.root != 0.0 || scene.saturation.tip != 0.0) {
      SaturationCommand init;
      init.root_value = scene.saturation.root;
      init.tip_value = scene.saturation.tip;
      applySaturation(model, init, pose, &state);
    }
    auto record = [&](int64_t t_ns, uint64_t step) {
      std_msgs::Header h;
      h.stamp = stamp(t_ns);
      h.frame_id = "world";
      out.emplace_back();
      stateToStrandsMsg(model, state, wet, h, step, 0, pose, &out.back());
    };
    record(t0_ns, 0);
    for (int k = 0; k < frames; ++k) {
      const int64_t t_ns = t0_ns + k * frame_ns;
      while (!due.empty() && due.begin()->first <= t_ns) {
        applySaturation(model, due.begin()->second, pose, &state);
        due.erase(due.begin());
      }
      StepInputs in;
      in.head_start = pose;
      in.head_end = lookup(t_ns + frame_ns);
      in.obstacles = obstacles.empty() ? nullptr : &obstacles;
      StepStats stats;
      step(model, scene.solver, in, frame_s, &state, &stats);
      pose = in.head_end;
      // Frames up to the last /tf message's record time: the loop restarts right after it.
      const bool replayed =
          t_ns + frame_ns <= t0_ns + frames * frame_ns - 2 * std::llround(lead_s * 1e9);
      if ((k + 1) % stride == 0 && replayed) record(t_ns + frame_ns, static_cast<uint64_t>(k + 1));
    }
    return out;
  };
  const std::vector<Strands> frames_out = simulate(0.0);
  rosbag::Bag expected(out_dir + "/replay_expected.bag", rosbag::bagmode::Write);
  for (const Strands& m : frames_out) expected.write("/wet_curly_hair/strands", m.header.stamp, m);
  const int written = static_cast<int>(frames_out.size());
  if (sensitivity_m > 0.0) {
    // How far round-off-sized input differences carry: the tolerance of the replay test must
    // hold them (a build for another CPU, e.g. without FMA, rounds differently).
    const std::vector<Strands> shifted = simulate(sensitivity_m);
    for (size_t f = 0; f < frames_out.size(); ++f) {
      double d = 0.0;
      for (size_t i = 0; i < frames_out[f].positions.size(); ++i) {
        const double x = frames_out[f].positions[i] - (i % 3 == 0 ? sensitivity_m : 0.0);
        d = std::max(d, std::abs(double(shifted[f].positions[i]) - x));
      }
      std::printf("sensitivity: head moved by %.3g m: frame %llu: largest particle change %.3g m\n",
                  sensitivity_m, static_cast<unsigned long long>(frames_out[f].step), d);
    }
  }
  expected.close();
  std::printf(
      "wrote %s/replay_input.bag (%d transforms, 2 saturation changes) and "
      "%s/replay_expected.bag (%d frames of %d strands, %d particles; frame %.4f s, "
      "first at t = %.3f s)\n",
      out_dir.c_str(), frames + 1, out_dir.c_str(), written, model.strandCount(),
      model.particleCount(), frame_s, t0_ns * 1e-9);
  return 0;
}
