// The node and the strands sink as nodelets (docs/ros.md, "Nodelets"): loaded into one nodelet
// manager, a subscriber to ~strands takes each frame as the shared pointer the node published,
// neither serialized nor copied (9 MB per frame at 10,000 strands). Anything outside the manager
// subscribes over TCPROS as to the node.
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <ros/serialization.h>
#include <std_msgs/UInt64.h>

#include <memory>
#include <pluginlib/class_list_macros.hpp>
#include <string>

#include "wet_curly_hair/Strands.h"
#include "wet_curly_hair/ros/node.h"

namespace wet_curly_hair {

/// wet_curly_hair/WetCurlyHairNodelet: WetCurlyHairNode with the nodelet's handles, the same
/// parameters, topics and services as wet_curly_hair_node. A parameter the node refuses is
/// reported as for the node and the nodelet then simulates nothing (a manager cannot exit for it).
class WetCurlyHairNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      node_ = std::make_unique<WetCurlyHairNode>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      NODELET_FATAL("not starting: %s", e.what());
    }
  }
  std::unique_ptr<WetCurlyHairNode> node_;
};

/// wet_curly_hair/StrandsSinkNodelet: wet_curly_hair_strands_sink in a manager. It takes each
/// frame of ~topic (default wet_curly_hair/strands, relative) as the publisher's own message and
/// publishes on ~received (std_msgs/UInt64) the size that frame has serialized, without
/// serializing it, so that bench/node_10k.sh --sink nodelet measures a consumer in the node's
/// process as --sink measures one in another.
class StrandsSinkNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    std::string topic;
    pnh.param<std::string>("topic", topic, "wet_curly_hair/strands");
    if (topic.empty()) {
      NODELET_ERROR("~topic: must name a topic; taking nothing");
      return;
    }
    received_ = pnh.advertise<std_msgs::UInt64>("received", 100);
    sub_ = getNodeHandle().subscribe(topic, 2, &StrandsSinkNodelet::onStrands, this);
    NODELET_INFO("taking %s in process", sub_.getTopic().c_str());
  }
  void onStrands(const Strands::ConstPtr& frame) {
    std_msgs::UInt64 size;
    size.data = ros::serialization::serializationLength(*frame);
    received_.publish(size);
  }
  ros::Publisher received_;
  ros::Subscriber sub_;
};

}  // namespace wet_curly_hair

PLUGINLIB_EXPORT_CLASS(wet_curly_hair::WetCurlyHairNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(wet_curly_hair::StrandsSinkNodelet, nodelet::Nodelet)
