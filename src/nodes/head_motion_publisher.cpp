// head_motion_publisher: broadcasts a scripted head motion on tf2 (docs/ros.md).
#include "wet_curly_hair/ros/head_motion_publisher.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "head_motion_publisher");
  ros::NodeHandle nh, pnh("~");
  try {
    wet_curly_hair::HeadMotionPublisher publisher(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("not starting: %s", e.what());
    return 1;
  }
  return 0;
}
