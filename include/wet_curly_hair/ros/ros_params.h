// ROS parameters -> configs: the one place where the node's private parameters are read, so that
// every parameter has one name, one default and one check. Everything starts from defaults, is
// overridden by the parameter server, and is validated; a bad value is refused with a message
// naming the parameter. The parameters are listed in docs/ros.md.
#pragma once

#include <ros/node_handle.h>

#include <string>
#include <vector>

#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/io/scene.h"

namespace wet_curly_hair {
/// Settings of the node itself (not of the scene). Each field is the private parameter of the
/// same name, `~field`.
struct NodeConfig {
  std::string world_frame = "world";  ///< fixed frame of every output and of gravity.
  std::string head_frame = "head";    ///< the head; its pose in world_frame comes from tf2.
  double publish_rate = 60.0;         ///< frames per second of ROS time, Hz; frame = 1 / rate.
  /// Longest wait for a head pose at a frame boundary, s of wall clock, counted from the newest
  /// transform's stamp (a publisher that stopped costs no wait).
  double tf_timeout_s = 0.05;
  /// Most frames one timer tick simulates; beyond that the node skips ahead (counted) instead of
  /// falling further behind ROS time.
  int max_catchup_frames = 10;
  bool publish_markers = true;          ///< publish ~markers (visualization_msgs/MarkerArray).
  double marker_line_width_m = 0.0015;  ///< LINE_LIST width in RViz, m.
  /// Most strands the hair marker draws: every ceil(N / max)-th strand beyond (0: all). At
  /// 10,000 strands the whole LINE_LIST is 25 MB per frame, more than RViz draws at 60 Hz.
  int marker_max_strands = 2000;
  /// tf2 frame of the scene's obstacle map file (scene parameters obstacle_map.*): "" places the
  /// map at obstacle_map.offset_m in world_frame; a frame places it there in that frame.
  std::string obstacle_map_frame;
  double map_frame_timeout_s = 2.0;  ///< longest wait for a map's frame over tf2, s.
  bool validate(std::string* why) const;
};

/// "solver.bend.stiffness_n_m2" -> "solver/bend/stiffness_n_m2" (relative to ~).
std::string rosParamName(const std::string& dotted);

/// Reads the scene: `~scene` ("" or "builtin": the built-in scene; a .yaml scene file, read on
/// top of the defaults as the offline runner does; a .hair file: the built-in scene with that
/// groom), then every dotted scene parameter given as a private ROS parameter
/// (~solver/bend/stiffness_n_m2), then validates. Refuses a parameter of the wrong type, a
/// private parameter under a scene namespace (groom, groom_file, head, solver, motion, run) that
/// is not a scene parameter, and any invalid value; *why names the parameter. *source describes
/// where the scene came from.
bool sceneFromRos(const ros::NodeHandle& pnh, io::SceneConfig* scene, std::string* source,
                  std::string* why);

/// Reads NodeConfig from the private parameters and validates it.
bool nodeConfigFromRos(const ros::NodeHandle& pnh, NodeConfig* config, std::string* why);

/// Writes every scene parameter under ~ (the parameter server mirror), typed as in the table.
void mirrorSceneToRos(const ros::NodeHandle& pnh, io::SceneConfig scene);
/// Writes only the named parameters (after ~set_parameters).
void mirrorSceneToRos(const ros::NodeHandle& pnh, io::SceneConfig scene,
                      const std::vector<std::string>& names);

/// Settings of the head motion publisher (~motion, ~rate, ~world_frame, ~head_frame,
/// ~base_xyz, ~base_rpy).
struct HeadMotionPublisherConfig {
  std::string world_frame = "world";
  std::string head_frame = "head";
  double rate = 100.0;  ///< broadcasts per second of ROS time, Hz.
  /// One or more core motions joined by '+', composed left to right about the head origin,
  /// e.g. "shake:freq_hz=0.25,amplitude_rad=0.5+nod:freq_hz=0.5,amplitude_rad=0.25".
  std::string motion = "nod";
  std::vector<HeadMotionConfig> motions;  ///< parsed from `motion`.
  Pose base;  ///< head pose at rest in the world (~base_xyz [m], ~base_rpy [rad]).
  bool validate(std::string* why) const;
};

/// Parses a '+'-joined motion spec; on failure *why names the part.
bool parseMotionChain(const std::string& spec, std::vector<HeadMotionConfig>* motions,
                      std::string* why);

bool headMotionPublisherConfigFromRos(const ros::NodeHandle& pnh, HeadMotionPublisherConfig* config,
                                      std::string* why);

}  // namespace wet_curly_hair
