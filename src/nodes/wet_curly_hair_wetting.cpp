// wet_curly_hair_wetting: wets the hair over time through the ~set_saturation service, as a
// user's node would: from ~start_s to ~start_s + ~duration_s (s of ROS time after its first
// tick) it sets, ~steps times, a root-to-tip ramp that grows linearly to ~root_value at the
// roots and ~tip_value at the tips (so water rises toward the tips). ~service is relative by
// default (wet_curly_hair/set_saturation), so in a namespace it calls that namespace's node.
#include <ros/ros.h>

#include <algorithm>

#include "wet_curly_hair/SetSaturation.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "wetting");
  ros::NodeHandle nh, pnh("~");
  const std::string service = pnh.param<std::string>("service", "wet_curly_hair/set_saturation");
  const double start_s = pnh.param("start_s", 1.0), duration_s = pnh.param("duration_s", 4.0);
  const double root = pnh.param("root_value", 0.1), tip = pnh.param("tip_value", 1.0);
  const int steps = pnh.param("steps", 20);
  if (!(start_s >= 0 && duration_s > 0 && steps >= 1)) {
    ROS_FATAL("not starting: need ~start_s >= 0, ~duration_s > 0, ~steps >= 1");
    return 1;
  }
  ros::ServiceClient client = nh.serviceClient<wet_curly_hair::SetSaturation>(service);
  const std::string resolved = client.getService();  // as resolved in this node's namespace
  if (!client.waitForExistence(ros::Duration(60.0))) {
    ROS_FATAL("%s did not appear within 60 s", resolved.c_str());
    return 1;
  }
  ros::Time t0;
  int done = 0;
  ros::Rate poll(100.0);
  while (ros::ok() && done < steps) {
    const ros::Time now = ros::Time::now();
    if (now.isZero()) {
      ros::WallDuration(0.01).sleep();
      continue;
    }
    if (t0.isZero()) t0 = now;
    const double due = start_s + duration_s * (done + 1) / steps;
    if ((now - t0).toSec() >= due) {
      const double f = static_cast<double>(done + 1) / steps;
      wet_curly_hair::SetSaturation srv;
      srv.request.root_value = static_cast<float>(root * f);
      srv.request.tip_value = static_cast<float>(tip * f);
      if (!client.call(srv))
        ROS_WARN("%s: call failed", resolved.c_str());
      else if (!srv.response.success)
        ROS_WARN("%s refused: %s", resolved.c_str(), srv.response.message.c_str());
      ++done;
    }
    poll.sleep();
  }
  ROS_INFO("wetting done: roots %.2f, tips %.2f", root, tip);
  return 0;
}
