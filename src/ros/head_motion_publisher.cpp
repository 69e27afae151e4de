#include "wet_curly_hair/ros/head_motion_publisher.h"

#include <geometry_msgs/TransformStamped.h>

#include <stdexcept>

namespace wet_curly_hair {

Pose headMotionChainPose(const HeadMotionPublisherConfig& config, double t_s) {
  Pose p = config.base;
  for (const HeadMotionConfig& m : config.motions) p = p * headPose(m, t_s);
  return p;
}

HeadMotionPublisher::HeadMotionPublisher(const ros::NodeHandle& nh, const ros::NodeHandle& pnh)
    : nh_(nh) {
  std::string why;
  if (!headMotionPublisherConfigFromRos(pnh, &config_, &why)) throw std::runtime_error(why);
  init();
}

HeadMotionPublisher::HeadMotionPublisher(const ros::NodeHandle& nh,
                                         const HeadMotionPublisherConfig& config)
    : nh_(nh), config_(config) {
  std::string why;
  if (!config_.validate(&why)) throw std::runtime_error(why);
  init();
}

void HeadMotionPublisher::init() {
  timer_ = nh_.createTimer(ros::Duration(1.0 / config_.rate), &HeadMotionPublisher::onTimer, this);
  ROS_INFO("head motion '%s' on %s -> %s at %.3g Hz", config_.motion.c_str(),
           config_.world_frame.c_str(), config_.head_frame.c_str(), config_.rate);
}

void HeadMotionPublisher::onTimer(const ros::TimerEvent&) {
  const ros::Time now = ros::Time::now();
  if (now.isZero()) return;  // sim time without a clock yet
  // Under sim time two ticks can fall on one /clock value: tf2 would drop the second transform
  // as repeated data (TF_REPEATED_DATA) and warn on every one.
  if (!start_.isZero() && now == last_) return;
  if (start_.isZero() || now < last_) {
    if (!start_.isZero()) ROS_WARN("ROS time jumped back: the head motion starts again");
    start_ = now;
  }
  last_ = now;
  const Pose p = headMotionChainPose(config_, (now - start_).toSec());
  geometry_msgs::TransformStamped t;
  t.header.stamp = now;
  t.header.frame_id = config_.world_frame;
  t.child_frame_id = config_.head_frame;
  t.transform.translation.x = p.translation.x();
  t.transform.translation.y = p.translation.y();
  t.transform.translation.z = p.translation.z();
  t.transform.rotation.x = p.rotation.x();
  t.transform.rotation.y = p.rotation.y();
  t.transform.rotation.z = p.rotation.z();
  t.transform.rotation.w = p.rotation.w();
  broadcaster_.sendTransform(t);
}

}  // namespace wet_curly_hair
