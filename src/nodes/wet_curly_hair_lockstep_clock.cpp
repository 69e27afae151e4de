// wet_curly_hair_lockstep_clock: publishes /clock for /use_sim_time runs in which the simulation
// is slower than real time. ROS time advances in ~step_s increments, but never more than
// ~max_lead_s ahead of the newest message on ~strands_topic (default /wet_curly_hair/strands),
// and never faster than ~max_rate times real time. So every frame is simulated (none skipped) and
// the run takes as long as the solver needs. If the simulation sends nothing for ~wall_timeout_s
// (stuck, or gone), time advances anyway, so nothing waits forever; before its first message
// time runs freely at ~max_rate.
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include <atomic>

#include "wet_curly_hair/Strands.h"

namespace {
std::atomic<int64_t> g_newest_ns{-1};
void onStrands(const wet_curly_hair::Strands::ConstPtr& m) {
  g_newest_ns = static_cast<int64_t>(m->header.stamp.toNSec());
}
}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "lockstep_clock");
  ros::NodeHandle nh, pnh("~");
  double step_s = pnh.param("step_s", 0.005), start_s = pnh.param("start_s", 1000.0);
  double max_lead_s = pnh.param("max_lead_s", 0.05), max_rate = pnh.param("max_rate", 1.0);
  double wall_timeout_s = pnh.param("wall_timeout_s", 5.0);
  const std::string topic = pnh.param<std::string>("strands_topic", "/wet_curly_hair/strands");
  if (!(step_s > 0 && start_s > 0 && max_lead_s >= 0 && max_rate > 0 && wall_timeout_s > 0)) {
    ROS_FATAL(
        "not starting: ~step_s, ~start_s, ~max_rate and ~wall_timeout_s must be > 0, "
        "~max_lead_s >= 0");
    return 1;
  }
  ros::Publisher clock = nh.advertise<rosgraph_msgs::Clock>("/clock", 1);
  ros::Subscriber sub = nh.subscribe(topic, 10, onStrands);
  ros::AsyncSpinner spinner(1);
  spinner.start();
  rosgraph_msgs::Clock c;
  c.clock = ros::Time(start_s);
  ros::WallTime last_advance = ros::WallTime::now();
  uint64_t forced = 0;
  while (ros::ok()) {
    clock.publish(c);
    ros::WallDuration(step_s / max_rate).sleep();
    const int64_t newest = g_newest_ns.load();
    // Until the first message, time runs freely (the simulation needs time to start at all).
    const bool caught_up =
        newest < 0 || newest >= static_cast<int64_t>(c.clock.toNSec()) - int64_t(max_lead_s * 1e9);
    if (caught_up || (ros::WallTime::now() - last_advance).toSec() > wall_timeout_s) {
      if (!caught_up && ++forced % 100 == 1)
        ROS_WARN("%s is more than %.3f s behind /clock: advancing anyway", topic.c_str(),
                 wall_timeout_s);
      c.clock += ros::Duration(step_s);
      last_advance = ros::WallTime::now();
    }
  }
  return 0;
}
