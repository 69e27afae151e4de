// Broadcasts the head frame over tf2 (~world_frame -> ~head_frame) from the core's scripted
// motions (still, spin, nod, shake, teleport, linear), on ROS time, so demos and tests need no
// robot. Motion time starts at the first tick and starts again when ROS time jumps back.
#pragma once

#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>

#include "wet_curly_hair/core/types.h"
#include "wet_curly_hair/ros/ros_params.h"

namespace wet_curly_hair {

/// Pose of the motion chain at motion time t_s: base * m_1(t) * m_2(t) * ... (each motion about
/// the head origin; the core motions' own base poses are the identity).
Pose headMotionChainPose(const HeadMotionPublisherConfig& config, double t_s);

class HeadMotionPublisher {
 public:
  /// Throws std::runtime_error naming the parameter on an invalid one.
  HeadMotionPublisher(const ros::NodeHandle& nh, const ros::NodeHandle& pnh);
  HeadMotionPublisher(const ros::NodeHandle& nh, const HeadMotionPublisherConfig& config);

 private:
  void init();
  void onTimer(const ros::TimerEvent& event);

  ros::NodeHandle nh_;
  HeadMotionPublisherConfig config_;
  tf2_ros::TransformBroadcaster broadcaster_;
  ros::Timer timer_;
  ros::Time start_, last_;
};

}  // namespace wet_curly_hair
