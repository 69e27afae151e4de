// The wet_curly_hair node: the ROS-free solver driven by ROS time, the head pose from tf2,
// obstacles from OctoMap, strands/status/markers out, services in (interface: docs/ros.md).
//
// Threads: the timer runs on the node handle's queue (the main thread under ros::spin);
// services and input topics run on a queue of their own (two threads), so that a service waiting
// for an obstacle field build never stalls the simulation; tf2 listens on its own thread; field
// builds run on a worker thread. One mutex guards the simulation, and the timer holds it only
// while it advances a frame: services and scheduled changes therefore act between frames.
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "wet_curly_hair/GetParameters.h"
#include "wet_curly_hair/LoadObstacleMap.h"
#include "wet_curly_hair/OctomapCompat.h"
#include "wet_curly_hair/SaturationChange.h"
#include "wet_curly_hair/SetParameters.h"
#include "wet_curly_hair/SetSaturation.h"
#include "wet_curly_hair/SetWater.h"
#include "wet_curly_hair/Status.h"
#include "wet_curly_hair/Strands.h"
#include "wet_curly_hair/WaterChange.h"
#include "wet_curly_hair/core/metrics.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/obstacles.h"
#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/core/water.h"
#include "wet_curly_hair/io/scene.h"
#include "wet_curly_hair/ros/obstacle_field_builder.h"
#include "wet_curly_hair/ros/ros_params.h"

namespace wet_curly_hair {

class WetCurlyHairNode {
 public:
  /// Reads every private parameter (ros_params.h). Throws std::runtime_error with a message
  /// naming the parameter when one is invalid, or when the scene or the start-up obstacle map
  /// cannot be loaded: the caller prints it with ROS_FATAL and exits.
  WetCurlyHairNode(const ros::NodeHandle& nh, const ros::NodeHandle& pnh);
  /// With explicit configs (tests, nodelets): parameters are not read, only mirrored.
  WetCurlyHairNode(const ros::NodeHandle& nh, const ros::NodeHandle& pnh, const NodeConfig& config,
                   const io::SceneConfig& scene, const std::string& scene_source);
  ~WetCurlyHairNode();
  WetCurlyHairNode(const WetCurlyHairNode&) = delete;
  WetCurlyHairNode& operator=(const WetCurlyHairNode&) = delete;

 private:
  struct PoseLookup {
    bool ok = false;
    Pose pose;
    int64_t stamp_ns = 0;  ///< stamp of the transform used, ns.
    std::string error;
  };
  /// What is known about the obstacle field in use (guarded by sim_mutex_).
  struct FieldInfo {
    bool loaded = false;
    std::string source;
    double map_stamp_s = -1.0;
    ros::WallTime swapped_at;
    int64_t cells = 0;
    ObstacleFieldBuilder::Request request;  ///< tree and box of the field in use (for rebuilds)
  };

  void init();
  void onTimer(const ros::TimerEvent& event);
  PoseLookup lookupHeadPose(int64_t t_ns, const ros::Time& now);
  // The following run with sim_mutex_ held.
  void advanceFrameLocked(int64_t t_end_ns, const PoseLookup& lookup);
  void resetHairLocked(const Pose& head_pose, const std::string& reason);
  /// Adds the crossings of the last frame (hair contact on only; Status.crossings).
  void countCrossingsLocked();
  void applyDueChangesLocked(int64_t t_ns);
  void stepWaterLocked();
  void swapInFieldLocked();
  void maybeRebuildFieldLocked();
  Eigen::AlignedBox3d reachBoxLocked() const;
  void publishStrandsLocked();
  /// A frame of strands_frames_ that nothing else holds, or a new one (kept up to 4).
  boost::shared_ptr<Strands> freeStrandsFrame();
  /// Head, obstacle and obstacle-field markers beside the hair in markers_msg_ (docs/ros.md).
  void appendSceneMarkersLocked(const std_msgs::Header& header);
  void fillStatusLocked(Status* status);

  bool onSetSaturation(SetSaturation::Request& req, SetSaturation::Response& res);
  bool onSetWater(SetWater::Request& req, SetWater::Response& res);
  void onWaterChange(const WaterChange::ConstPtr& msg);
  bool onSetParameters(SetParameters::Request& req, SetParameters::Response& res);
  bool onGetParameters(GetParameters::Request& req, GetParameters::Response& res);
  bool onReset(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  bool onLoadObstacleMap(LoadObstacleMap::Request& req, LoadObstacleMap::Response& res);
  void onOctomap(const OctomapCompat::ConstPtr& msg);
  void onSaturationChange(const SaturationChange::ConstPtr& msg);
  void onFieldBuilt(const ObstacleFieldBuilder::Result& result);
  /// Places a tree in the world over tf2 and queues its field; false with a reason when the
  /// frame does not resolve within ~map_frame_timeout_s (counted as a refused map).
  bool submitTree(std::shared_ptr<const octomap::OcTree> tree, const std::string& frame_id,
                  const Vec3& offset_m, const io::SdfBuildConfig& sdf, const std::string& source,
                  double stamp_s, ObstacleFieldBuilder::Callback done, std::string* why);
  /// Loads the scene's obstacle map file and builds its field, waiting for the build (the
  /// field is then swapped in before the next frame). False with the reason, counted.
  bool buildSceneMap(const io::SceneConfig& scene, std::string* message);
  static io::SdfBuildConfig sdfConfigOf(const io::SceneConfig& scene);
  void refuseMap(const std::string& why);

  ros::NodeHandle nh_, pnh_;
  ros::NodeHandle nh_input_, pnh_input_;  ///< on input_queue_
  NodeConfig config_;
  std::string scene_source_;
  std::vector<std::string> user_scene_params_;  ///< ROS names the user set (kept at exit)
  std::map<std::string, XmlRpc::XmlRpcValue> user_scene_values_;
  int64_t frame_ns_ = 0;
  double frame_s_ = 0.0;

  ros::CallbackQueue input_queue_;
  std::unique_ptr<ros::AsyncSpinner> input_spinner_;
  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  ros::Publisher strands_pub_, status_pub_, markers_pub_;
  ros::Subscriber octomap_sub_, saturation_sub_, water_sub_;
  ros::ServiceServer set_water_srv_;
  ros::ServiceServer set_saturation_srv_, set_parameters_srv_, get_parameters_srv_, reset_srv_,
      load_map_srv_;
  ros::Timer timer_;

  std::mutex params_mutex_;  ///< one ~set_parameters at a time
  // ---- simulation (sim_mutex_)
  std::mutex sim_mutex_;
  io::SceneConfig scene_;
  HairModel model_;
  uint32_t strands_skipped_ = 0;  ///< strands of the groom file not simulated (Status)
  HairState state_;
  Obstacles obstacles_;
  double reach_radius_m_ = 0.0;  ///< farthest a particle can be from the head origin, m
  bool started_ = false;
  int64_t sim_ns_ = 0;  ///< simulated instant of state_, ns of ROS time
  ros::Time last_now_;
  Pose head_pose_;                   ///< pose of state_ (end of the last frame)
  bool pose_ever_ = false;           ///< a pose came from tf2 since the last reset
  int64_t last_pose_stamp_ns_ = -1;  ///< stamp of the last pose from tf2
  bool head_pose_ok_ = false;
  std::string tf_error_;
  uint64_t step_ = 0;
  uint32_t reset_count_ = 0;
  std::string last_reset_reason_;
  uint64_t skipped_frames_ = 0;
  uint64_t markers_published_ = 0;  ///< ~markers messages published (only while subscribed).
  uint32_t time_jumps_back_ = 0;
  uint64_t tf_lookups_ = 0, tf_fallbacks_ = 0;
  std::multimap<int64_t, SaturationCommand> pending_changes_;  ///< by stamp, ns
  /// Water (docs/water.md): the sources and dryers in use (the scene's, then as ~set_water and
  /// ~water_changes change them), whether the stage runs, scheduled changes by stamp (ns).
  struct WaterCommand {
    bool clear = false;
    WaterSources add;
  };
  WaterSources water_sources_;
  bool water_active_ = false;
  std::multimap<int64_t, WaterCommand> pending_water_;
  double water_step_s_ = 0.0;  ///< the water stage of the last frame, wall, s
  StepStats last_stats_;
  // Crossings while hair contact is on (Status.crossings): the last frame's positions.
  MetricScratch crossing_scratch_;
  Vec3List previous_position_;
  long long crossings_ = 0;
  FieldInfo field_;
  /// The ~strands frames, published as shared pointers: a subscriber in the node's process (a
  /// nodelet in its manager) takes the frame itself, neither serialized nor copied. A frame is
  /// filled again only once nothing else holds it (freeStrandsFrame).
  std::vector<boost::shared_ptr<Strands>> strands_frames_;
  size_t next_strands_frame_ = 0;  ///< the slot replaced when every frame is held
  visualization_msgs::MarkerArray markers_msg_;
  std::set<std::pair<std::string, int32_t>> published_markers_;  ///< (ns, id) sent last time
  visualization_msgs::Marker field_marker_;        ///< the field's surface, made once per field
  std::weak_ptr<const DenseSdf> field_marker_of_;  ///< the field field_marker_ was made from
  // timing of the current tick (wall, s)
  double tick_step_s_ = 0.0, tick_convert_s_ = 0.0, tick_publish_s_ = 0.0, tick_tf_s_ = 0.0;
  int tick_frames_ = 0;
  // real-time factor window
  ros::WallTime rtf_wall_start_;
  uint64_t frames_stepped_ = 0, rtf_frames_start_ = 0;
  double real_time_factor_ = 0.0;
  ros::WallTime skip_warned_at_, tf_warned_at_;  ///< warnings throttled on the wall clock

  // ---- finished builds waiting to be swapped in (field_mutex_)
  std::mutex field_mutex_;
  bool field_ready_ = false;
  bool field_remove_ = false;
  ObstacleFieldBuilder::Result ready_;
  double last_build_s_ = 0.0;
  uint32_t maps_refused_ = 0;
  std::string map_error_;

  std::unique_ptr<ObstacleFieldBuilder> builder_;
};

/// ros::spin() until SIGINT, SIGTERM or a shutdown request. Call ros::init with
/// ros::init_options::NoSigintHandler, then ros::shutdown() and destroy the node (which removes
/// its parameter mirror: see ~WetCurlyHairNode).
void spinUntilSignal();

}  // namespace wet_curly_hair
