// The node and the strands sink as nodelets (docs/ros.md, "Nodelets"): loaded into one nodelet
// manager, a subscriber to ~strands takes each frame as the shared pointer the node published,
// neither serialized nor copied (9 MB per frame at 10,000 strands). Anything outside the manager
// subscribes over TCPROS as to the node.
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <ros/serialization.h>
#include <std_msgs/UInt64.h>

#include <deque>
#include <memory>
#include <pluginlib/class_list_macros.hpp>
#include <string>

#include "wet_curly_hair/Strands.h"
#include "wet_curly_hair/ros/node.h"

namespace wet_curly_hair {

/// wet_curly_hair/WetCurlyHairNodelet: WetCurlyHairNode with the nodelet's handles, the same
/// parameters, topics and services as wet_curly_hair_node. A parameter the node refuses is
/// reported as the node reports it, and the load fails: the manager unloads the nodelet (the
/// `nodelet load` process exits) and runs on with its other nodelets.
class WetCurlyHairNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      node_ = std::make_unique<WetCurlyHairNode>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      NODELET_FATAL("not starting: %s", e.what());  // the manager's own message has no reason
      throw;
    }
  }
  std::unique_ptr<WetCurlyHairNode> node_;
};

/// wet_curly_hair/StrandsSinkNodelet: wet_curly_hair_strands_sink in a manager. It takes each
/// frame of ~topic (default wet_curly_hair/strands, relative) as the publisher's own message and
/// publishes on ~received (std_msgs/UInt64) the size that frame has serialized, without
/// serializing it, so that bench/node_10k.sh --sink --nodelet measures a consumer in the node's
/// process as --sink measures one in another. ~keep_frames k (default 0, at most 64): it also keeps
/// the last k frames, as a consumer comparing successive frames would, and publishes on ~changed
/// (std_msgs/UInt64) how many kept frames no longer hold what they held on arrival (their step
/// and a checksum of their positions): 0 unless the publisher wrote into a frame still held.
class StrandsSinkNodelet : public nodelet::Nodelet {
 private:
  struct Kept {
    Strands::ConstPtr frame;
    uint64_t step;
    double checksum;
  };
  void onInit() override {
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    std::string topic;
    pnh.param<std::string>("topic", topic, "wet_curly_hair/strands");
    int keep = 0;
    pnh.param("keep_frames", keep, 0);
    if (topic.empty() || keep < 0 || keep > 64) {
      NODELET_ERROR("%s; taking nothing", topic.empty() ? "~topic: must name a topic"
                                                        : "~keep_frames: must be in [0, 64]");
      return;
    }
    keep_ = static_cast<size_t>(keep);
    received_ = pnh.advertise<std_msgs::UInt64>("received", 100);
    changed_ = pnh.advertise<std_msgs::UInt64>("changed", 100);
    sub_ = getNodeHandle().subscribe(topic, 2, &StrandsSinkNodelet::onStrands, this);
    NODELET_INFO("taking %s in process", sub_.getTopic().c_str());
  }
  static double checksum(const Strands& f) {
    double sum = 0.0;
    for (size_t k = 0; k < f.positions.size(); ++k) sum += (k % 7 + 1) * double(f.positions[k]);
    return sum;
  }
  void onStrands(const Strands::ConstPtr& frame) {
    std_msgs::UInt64 size;
    size.data = ros::serialization::serializationLength(*frame);
    received_.publish(size);
    if (keep_ == 0) return;
    std_msgs::UInt64 changed;
    for (const Kept& k : kept_)
      changed.data += k.frame->step != k.step || !(checksum(*k.frame) == k.checksum);
    changed_.publish(changed);
    kept_.push_back({frame, frame->step, checksum(*frame)});
    if (kept_.size() > keep_) kept_.pop_front();
  }
  size_t keep_ = 0;
  std::deque<Kept> kept_;
  ros::Publisher received_, changed_;
  ros::Subscriber sub_;
};

}  // namespace wet_curly_hair

PLUGINLIB_EXPORT_CLASS(wet_curly_hair::WetCurlyHairNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(wet_curly_hair::StrandsSinkNodelet, nodelet::Nodelet)
