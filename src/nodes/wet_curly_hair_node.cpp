// wet_curly_hair_node: wet curly hair on the head frame of tf2 (docs/ros.md).
#include <memory>

#include "wet_curly_hair/ros/node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "wet_curly_hair", ros::init_options::NoSigintHandler);
  ros::NodeHandle nh, pnh("~");
  std::unique_ptr<wet_curly_hair::WetCurlyHairNode> node;
  try {
    node = std::make_unique<wet_curly_hair::WetCurlyHairNode>(nh, pnh);
  } catch (const std::exception& e) {
    ROS_FATAL("not starting: %s", e.what());
    return 1;
  }
  wet_curly_hair::spinUntilSignal();
  ros::shutdown();  // first: master calls are then tried once, never retried against a dead master
  node.reset();     // removes the parameter mirror
  return 0;
}
