// wet_curly_hair_lockstep_clock: publishes /clock for /use_sim_time runs in which the simulation
// is slower than real time. ROS time advances in ~step_s increments, but never more than
// ~max_lead_s ahead of the newest message on each strands topic, and never faster than ~max_rate
// times real time. So every frame is simulated (none skipped) and the run takes as long as the
// solver needs. The topics: ~strands_topics (a list, one per head: the clock waits for the
// slowest) or ~strands_topic (one; default wet_curly_hair/strands, relative so that it resolves
// in the clock's namespace). If a simulation sends nothing for ~wall_timeout_s (stuck, or gone),
// time advances anyway, so nothing waits forever; a topic holds the clock back only once its first
// message has arrived, and before any has, time runs freely at ~max_rate.
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "wet_curly_hair/Strands.h"

namespace {

/// The newest stamp of one strands topic (-1 before its first message).
struct Follower {
  std::string topic;
  std::atomic<int64_t> newest_ns{-1};
  ros::Subscriber sub;
  void onStrands(const wet_curly_hair::Strands::ConstPtr& m) {
    newest_ns = static_cast<int64_t>(m->header.stamp.toNSec());
  }
};

/// The topics from ~strands_topics or ~strands_topic; false (with why) on a bad value.
bool readTopics(const ros::NodeHandle& pnh, std::vector<std::string>* topics, std::string* why) {
  if (pnh.hasParam("strands_topics")) {
    if (!pnh.getParam("strands_topics", *topics) || topics->empty()) {
      *why = "~strands_topics: must be a non-empty list of topic names";
      return false;
    }
    return true;
  }
  topics->assign(1, pnh.param<std::string>("strands_topic", "wet_curly_hair/strands"));
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "lockstep_clock");
  ros::NodeHandle nh, pnh("~");
  double step_s = pnh.param("step_s", 0.005), start_s = pnh.param("start_s", 1000.0);
  double max_lead_s = pnh.param("max_lead_s", 0.05), max_rate = pnh.param("max_rate", 1.0);
  double wall_timeout_s = pnh.param("wall_timeout_s", 5.0);
  std::vector<std::string> topics;
  std::string why;
  if (!readTopics(pnh, &topics, &why)) {
    ROS_FATAL("not starting: %s", why.c_str());
    return 1;
  }
  if (!(step_s > 0 && start_s > 0 && max_lead_s >= 0 && max_rate > 0 && wall_timeout_s > 0)) {
    ROS_FATAL(
        "not starting: ~step_s, ~start_s, ~max_rate and ~wall_timeout_s must be > 0, "
        "~max_lead_s >= 0");
    return 1;
  }
  ros::Publisher clock = nh.advertise<rosgraph_msgs::Clock>("/clock", 1);
  std::vector<std::unique_ptr<Follower>> followers;
  for (const std::string& t : topics) {
    followers.push_back(std::make_unique<Follower>());
    Follower* f = followers.back().get();
    f->sub = nh.subscribe(t, 10, &Follower::onStrands, f);
    f->topic = f->sub.getTopic();
    ROS_INFO("lock-step on %s", f->topic.c_str());
  }
  ros::AsyncSpinner spinner(1);
  spinner.start();
  rosgraph_msgs::Clock c;
  c.clock = ros::Time(start_s);
  ros::WallTime last_advance = ros::WallTime::now();
  uint64_t forced = 0;
  while (ros::ok()) {
    clock.publish(c);
    ros::WallDuration(step_s / max_rate).sleep();
    const int64_t bound_ns = static_cast<int64_t>(c.clock.toNSec()) - int64_t(max_lead_s * 1e9);
    // Until its first message a topic does not hold time back (its node needs time to start).
    const Follower* behind = nullptr;
    for (const auto& f : followers) {
      const int64_t newest = f->newest_ns.load();
      if (newest >= 0 && newest < bound_ns) behind = f.get();
    }
    if (!behind || (ros::WallTime::now() - last_advance).toSec() > wall_timeout_s) {
      if (behind && ++forced % 100 == 1)
        ROS_WARN("%s is more than %.3f s behind /clock: advancing anyway", behind->topic.c_str(),
                 wall_timeout_s);
      c.clock += ros::Duration(step_s);
      last_advance = ros::WallTime::now();
    }
  }
  for (auto& f : followers) f->sub.shutdown();  // before the followers go away
  spinner.stop();
  return 0;
}
