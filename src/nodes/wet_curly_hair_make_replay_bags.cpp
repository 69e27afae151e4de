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
#include <vector>

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

struct Options {
  std::string scene_path, out_dir = ".";
  std::string motion =
      "shake:freq_hz=1.0,amplitude_rad=0.5,start_s=0.3+"
      "nod:freq_hz=0.7,amplitude_rad=0.3,start_s=0.6";
  double rate = 50.0, seconds = 3.0, start_s = 100.0, lead_s = 0.2;
  int stride = 5;
  double sensitivity_m = 0.0;
  bool help = false;
};

/// False (usage printed) on an unknown option or a missing value.
bool parseOptions(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      o->help = true;
      return true;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "%s", kUsage);
      return false;
    }
    const std::string v = argv[++i];
    if (a == "--scene")
      o->scene_path = v;
    else if (a == "--out-dir")
      o->out_dir = v;
    else if (a == "--rate")
      o->rate = std::atof(v.c_str());
    else if (a == "--seconds")
      o->seconds = std::atof(v.c_str());
    else if (a == "--start-s")
      o->start_s = std::atof(v.c_str());
    else if (a == "--motion")
      o->motion = v;
    else if (a == "--stride")
      o->stride = std::atoi(v.c_str());
    else if (a == "--tf-lead-s")
      o->lead_s = std::atof(v.c_str());
    else if (a == "--sensitivity-m")
      o->sensitivity_m = std::atof(v.c_str());
    else {
      std::fprintf(stderr, "unknown option %s\n%s", a.c_str(), kUsage);
      return false;
    }
  }
  return true;
}

ros::Time stamp(int64_t ns) {
  ros::Time t;
  t.fromNSec(static_cast<uint64_t>(ns));
  return t;
}

/// The node's frame grid: frame_ns = round(1e9 / rate), boundaries at multiples of it.
struct FrameGrid {
  int64_t frame_ns, t0_ns, lead_ns;
  double frame_s;
  int frames;
  explicit FrameGrid(const Options& o)
      : frame_ns(std::llround(1e9 / o.rate)),
        t0_ns((std::llround(o.start_s * 1e9) / frame_ns) * frame_ns),
        lead_ns(std::llround(o.lead_s * 1e9)),
        frame_s(frame_ns * 1e-9),
        frames(static_cast<int>(std::llround(o.seconds / frame_s))) {}
};

/// The head transforms on /tf, written to the input bag and kept in `buffer` for the lookups.
void writeHeadTransforms(const wet_curly_hair::HeadMotionPublisherConfig& head,
                         const FrameGrid& grid, rosbag::Bag* input, tf2::BufferCore* buffer) {
  {
    // The bag starts 1 s before the first head transform with a transform of another frame:
    // when a looping replay jumps back, tf2_ros's listener clears its buffer on the first /tf
    // message it gets after seeing the new time, which may be the message after the one that
    // triggered the jump; that one must not be the first head transform.
    geometry_msgs::TransformStamped tr;
    tr.header.stamp = stamp(grid.t0_ns - 1000000000);
    tr.header.frame_id = "world";
    tr.child_frame_id = "replay_bag_start";
    tr.transform.rotation.w = 1.0;
    tf2_msgs::TFMessage msg;
    msg.transforms.push_back(tr);
    input->write("/tf", tr.header.stamp, msg);
  }
  for (int k = 0; k <= grid.frames; ++k) {
    const int64_t t_ns = grid.t0_ns + k * grid.frame_ns;
    const wet_curly_hair::Pose p = wet_curly_hair::headMotionChainPose(head, k * grid.frame_s);
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
    input->write("/tf", stamp(t_ns - grid.lead_ns), msg);
    buffer->setTransform(tr, "replay");
  }
}

/// Two scheduled saturation changes: water rising to the tips, then a splash on some strands.
/// Written to the input bag; returned as the commands the node applies, by stamp.
std::multimap<int64_t, wet_curly_hair::SaturationCommand> writeSaturationChanges(
    const FrameGrid& grid, rosbag::Bag* input) {
  using wet_curly_hair::SaturationChange;
  std::multimap<int64_t, wet_curly_hair::SaturationCommand> changes;
  std::string why;
  SaturationChange m;
  m.header.stamp = stamp(grid.t0_ns + std::llround(1.0 * 1e9));
  m.root_value = 0.0f;
  m.tip_value = 1.0f;
  input->write("/wet_curly_hair/saturation_changes", stamp(m.header.stamp.toNSec() - 500000000), m);
  wet_curly_hair::SaturationCommand c;
  wet_curly_hair::saturationCommandFromMsg(m, &c, &why);
  changes.emplace(m.header.stamp.toNSec(), c);
  SaturationChange s;
  s.header.stamp = stamp(grid.t0_ns + std::llround(1.7 * 1e9));
  s.strands = {0, 3, 5, 8, 13};
  s.root_value = 0.4f;
  s.tip_value = 0.2f;
  s.add = true;
  s.region_type = SaturationChange::REGION_SPHERE;
  s.region_frame = SaturationChange::FRAME_HEAD;
  s.region_center.z = -0.05;
  s.region_radius = 0.15;
  input->write("/wet_curly_hair/saturation_changes", stamp(s.header.stamp.toNSec() - 500000000), s);
  wet_curly_hair::saturationCommandFromMsg(s, &c, &why);
  changes.emplace(s.header.stamp.toNSec(), c);
  return changes;
}

/// The node's computation, frame by frame, on the head poses of `buffer`.
struct Simulation {
  const wet_curly_hair::io::SceneConfig& scene;
  const wet_curly_hair::HairModel& model;
  const FrameGrid& grid;
  const tf2::BufferCore& buffer;
  const std::multimap<int64_t, wet_curly_hair::SaturationCommand>& changes;
  int stride;

  /// The expected frames; `perturb_m` shifts every head position by that much along x.
  std::vector<wet_curly_hair::Strands> run(double perturb_m) const {
    using namespace wet_curly_hair;
    Obstacles obstacles;
    obstacles.analytic = scene.obstacles;
    const bool wet = scene.solver.cohesion.mode != "off";
    std::vector<Strands> out;
    std::multimap<int64_t, SaturationCommand> due = changes;
    auto lookup = [&](int64_t t_ns) {
      Pose p;
      poseFromTransform(buffer.lookupTransform("world", "head", stamp(t_ns)).transform, &p);
      p.translation.x() += perturb_m;
      return p;
    };
    Pose pose = lookup(grid.t0_ns);
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
    record(grid.t0_ns, 0);
    for (int k = 0; k < grid.frames; ++k) {
      const int64_t t_ns = grid.t0_ns + k * grid.frame_ns;
      while (!due.empty() && due.begin()->first <= t_ns) {
        applySaturation(model, due.begin()->second, pose, &state);
        due.erase(due.begin());
      }
      StepInputs in;
      in.head_start = pose;
      in.head_end = lookup(t_ns + grid.frame_ns);
      in.obstacles = obstacles.empty() ? nullptr : &obstacles;
      StepStats stats;
      step(model, scene.solver, in, grid.frame_s, &state, &stats);
      pose = in.head_end;
      // Frames up to the last /tf message's record time: the loop restarts right after it.
      const bool replayed =
          t_ns + grid.frame_ns <= grid.t0_ns + grid.frames * grid.frame_ns - 2 * grid.lead_ns;
      if ((k + 1) % stride == 0 && replayed)
        record(t_ns + grid.frame_ns, static_cast<uint64_t>(k + 1));
    }
    return out;
  }
};

/// How far round-off-sized input differences carry: the tolerance of the replay test must hold
/// them (a build for another CPU, e.g. without FMA, rounds differently).
void printSensitivity(const Simulation& sim, const std::vector<wet_curly_hair::Strands>& frames,
                      double sensitivity_m) {
  const std::vector<wet_curly_hair::Strands> shifted = sim.run(sensitivity_m);
  for (size_t f = 0; f < frames.size(); ++f) {
    double d = 0.0;
    for (size_t i = 0; i < frames[f].positions.size(); ++i) {
      const double x = frames[f].positions[i] - (i % 3 == 0 ? sensitivity_m : 0.0);
      d = std::max(d, std::abs(double(shifted[f].positions[i]) - x));
    }
    std::printf("sensitivity: head moved by %.3g m: frame %llu: largest particle change %.3g m\n",
                sensitivity_m, static_cast<unsigned long long>(frames[f].step), d);
  }
}

}  // namespace

int main(int argc, char** argv) {
  using namespace wet_curly_hair;
  Options o;
  if (!parseOptions(argc, argv, &o)) return 2;
  if (o.help) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  io::SceneConfig scene;
  std::string why;
  if (o.scene_path.empty() || !io::loadSceneFile(o.scene_path, &scene, &why)) {
    std::fprintf(stderr, "wet_curly_hair_make_replay_bags: --scene: %s\n", why.c_str());
    return 2;
  }
  HeadMotionPublisherConfig head;
  if (!parseMotionChain(o.motion, &head.motions, &why)) {
    std::fprintf(stderr, "wet_curly_hair_make_replay_bags: %s\n", why.c_str());
    return 2;
  }
  const FrameGrid grid(o);
  rosbag::Bag input(o.out_dir + "/replay_input.bag", rosbag::bagmode::Write);
  tf2::BufferCore buffer(ros::Duration(3600.0));
  writeHeadTransforms(head, grid, &input, &buffer);
  const std::multimap<int64_t, SaturationCommand> changes = writeSaturationChanges(grid, &input);
  input.close();

  HairModel model;
  if (!io::buildSceneModel(scene, &model, &why)) {
    std::fprintf(stderr, "wet_curly_hair_make_replay_bags: %s\n", why.c_str());
    return 1;
  }
  const Simulation sim{scene, model, grid, buffer, changes, o.stride};
  const std::vector<Strands> frames_out = sim.run(0.0);
  rosbag::Bag expected(o.out_dir + "/replay_expected.bag", rosbag::bagmode::Write);
  for (const Strands& m : frames_out) expected.write("/wet_curly_hair/strands", m.header.stamp, m);
  if (o.sensitivity_m > 0.0) printSensitivity(sim, frames_out, o.sensitivity_m);
  expected.close();
  std::printf(
      "wrote %s/replay_input.bag (%d transforms, 2 saturation changes) and "
      "%s/replay_expected.bag (%d frames of %d strands, %d particles; frame %.4f s, "
      "first at t = %.3f s)\n",
      o.out_dir.c_str(), grid.frames + 1, o.out_dir.c_str(), static_cast<int>(frames_out.size()),
      model.strandCount(), model.particleCount(), grid.frame_s, grid.t0_ns * 1e-9);
  return 0;
}
