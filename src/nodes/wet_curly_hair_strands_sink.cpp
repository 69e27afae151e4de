// wet_curly_hair_strands_sink: a consumer of a strands topic that costs the publisher what any
// subscriber costs it (each message serialized and sent over TCPROS) and costs its own machine as
// little as a subscriber can: it takes each message as raw bytes (topic_tools::ShapeShifter),
// deserializes nothing, and publishes on ~received (std_msgs/UInt64) the serialized size of each
// message it took. ~topic: the topic (default wet_curly_hair/strands, relative, so that it resolves
// in the sink's namespace). bench/node_10k.sh --sink uses it to measure the node publishing to a
// subscriber without a Python receiver taking the cores (docs/followers.md, "10,000 strands").
#include <ros/ros.h>
#include <std_msgs/UInt64.h>
#include <topic_tools/shape_shifter.h>

#include <string>

int main(int argc, char** argv) {
  ros::init(argc, argv, "wet_curly_hair_strands_sink");
  ros::NodeHandle nh, pnh("~");
  std::string topic;
  pnh.param<std::string>("topic", topic, "wet_curly_hair/strands");
  if (topic.empty()) {
    ROS_ERROR("~topic: must name a topic");
    return 2;
  }
  ros::Publisher received = pnh.advertise<std_msgs::UInt64>("received", 100);
  boost::function<void(const topic_tools::ShapeShifter::ConstPtr&)> on_message =
      [&received](const topic_tools::ShapeShifter::ConstPtr& m) {
        std_msgs::UInt64 size;
        size.data = m->size();
        received.publish(size);
      };
  ros::Subscriber sub = nh.subscribe<topic_tools::ShapeShifter>(topic, 2, on_message);
  ROS_INFO("taking %s as raw bytes", sub.getTopic().c_str());
  ros::spin();
  return 0;
}
