// Conversions between the core's types and ROS messages: the state as a Strands message and as
// an RViz LINE_LIST, the head and the obstacles as RViz markers, poses, and saturation requests. No
// ROS node handles here: pure functions, unit-tested without a master
// (test/ros/test_ros_conversions.cpp).
#pragma once

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <cstdint>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "wet_curly_hair/Strands.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/obstacles.h"
#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Fills *msg from the state (positions and saturation as float32; wet_positions only when
/// `with_wet_positions`), the arrays converted on `threads` threads (the same values for any
/// count). Reuses the message's storage: no allocation once sized.
void stateToStrandsMsg(const HairModel& model, const HairState& state, bool with_wet_positions,
                       const std_msgs::Header& header, uint64_t step, uint32_t reset_count,
                       const Pose& head_pose, Strands* msg, int threads = 1);

/// Saturation shown as colour: dry is a light tan, fully wet a deep blue (linear blend, s
/// clamped to [0, 1], non-finite taken as 0). rgb in [0, 1].
void saturationColor(double s, float* r, float* g, float* b);

/// Resets *markers to one LINE_LIST marker (ns "wet_curly_hair/strands", id 0) holding every edge
/// of every strand (of every strand_stride-th strand: 0, k, 2k, ...), two points per edge, each
/// vertex coloured by its particle's saturation. Uses the cohesion display positions when
/// `use_wet_positions` (what the user should see), else the positions.
void stateToMarkerArray(const HairModel& model, const HairState& state, bool use_wet_positions,
                        const std_msgs::Header& header, double line_width_m,
                        visualization_msgs::MarkerArray* markers, int strand_stride = 1);

/// The stride that keeps at most max_strands of `strands` (0: all): ceil(strands / max_strands).
int markerStrandStride(int strands, int max_strands);

/// Marker namespaces on ~markers (docs/ros.md).
constexpr const char* kStrandsMarkerNs = "wet_curly_hair/strands";
constexpr const char* kHeadMarkerNs = "wet_curly_hair/head";
constexpr const char* kObstacleMarkerNs = "wet_curly_hair/obstacles";
constexpr const char* kObstacleFieldMarkerNs = "wet_curly_hair/obstacle_field";

/// Appends the head's collision shapes placed at head_pose (world <- head), in header's frame
/// (the world frame): the ellipsoid as a SPHERE scaled to its diameters (id 0), and each
/// capsule k as a CYLINDER (id 1 + 3k) with its two end caps as SPHEREs (ids 2 + 3k, 3 + 3k),
/// RViz having no capsule.
void appendHeadMarkers(const HeadShape& head, const Pose& head_pose, const std_msgs::Header& header,
                       visualization_msgs::MarkerArray* markers);

/// Appends one marker per analytic obstacle, id = its index: a SPHERE, an oriented CUBE, and for
/// a plane a square CUBE of side plane_size_m and 2 mm thickness lying on the plane, centred at
/// the point of the plane nearest to `near_m` (the head), since an infinite plane cannot be drawn.
void appendObstacleMarkers(const std::vector<AnalyticObstacle>& obstacles, const Vec3& near_m,
                           double plane_size_m, const std_msgs::Header& header,
                           visualization_msgs::MarkerArray* markers);

/// The obstacle field's surface as one CUBE_LIST (ns kObstacleFieldMarkerNs, id 0), placed by
/// field_in_world: the voxels at or below zero distance that have a face neighbour above zero
/// (the interior would be hidden anyway). When there are more than max_cubes of them, voxels are
/// merged into blocks of k x k x k (k the smallest that fits; a block is drawn when any of its
/// voxels is), so the message stays bounded whatever the map. Returns the block edge k in voxels,
/// or 0 (and an empty CUBE_LIST) when there is no field or max_cubes is 0.
int obstacleFieldMarker(const ObstacleField& field, size_t max_cubes,
                        const std_msgs::Header& header, visualization_msgs::Marker* marker);

/// `published` holds the (ns, id) of the markers published last time: a DELETE is appended for
/// each one that *markers no longer holds (an obstacle removed, a capsule less), so RViz does not
/// keep drawing it. Then `published` becomes the keys of *markers.
void deleteVanishedMarkers(std::set<std::pair<std::string, int32_t>>* published,
                           visualization_msgs::MarkerArray* markers);

geometry_msgs::Pose poseToMsg(const Pose& pose);
/// From a tf2 transform (target <- source): x_target = R x_source + t. The quaternion is
/// normalised; false (output unchanged) when it is not finite or has zero length.
bool poseFromTransform(const geometry_msgs::Transform& t, Pose* pose);

/// Region and selection fields shared by SetSaturation requests and SaturationChange messages.
/// Checks what the core cannot (region type and frame codes, finite region fields); the core's
/// validateSaturationCommand checks the rest against the model.
template <class Msg>
bool saturationCommandFromMsg(const Msg& m, SaturationCommand* cmd, std::string* why) {
  SaturationCommand c;
  c.strands.assign(m.strands.begin(), m.strands.end());
  c.root_value = m.root_value;
  c.tip_value = m.tip_value;
  c.add = m.add;
  if (m.region_frame != Msg::FRAME_WORLD && m.region_frame != Msg::FRAME_HEAD) {
    *why = "region_frame: " + std::to_string(m.region_frame) +
           " is not FRAME_WORLD (0) or FRAME_HEAD (1)";
    return false;
  }
  c.region.in_head_frame = m.region_frame == Msg::FRAME_HEAD;
  c.region.center_m = Vec3(m.region_center.x, m.region_center.y, m.region_center.z);
  c.region.radius_m = m.region_radius;
  c.region.half_extents_m =
      Vec3(m.region_half_extents.x, m.region_half_extents.y, m.region_half_extents.z);
  switch (m.region_type) {
    case Msg::REGION_NONE:
      c.region.kind = SaturationRegion::Kind::kEverywhere;
      break;
    case Msg::REGION_SPHERE:
      c.region.kind = SaturationRegion::Kind::kSphere;
      break;
    case Msg::REGION_BOX:
      c.region.kind = SaturationRegion::Kind::kBox;
      break;
    default:
      *why = "region_type: " + std::to_string(m.region_type) +
             " is not REGION_NONE (0), REGION_SPHERE (1) or REGION_BOX (2)";
      return false;
  }
  if (c.region.kind != SaturationRegion::Kind::kEverywhere && !c.region.center_m.allFinite()) {
    *why = "region_center: not finite";
    return false;
  }
  *cmd = c;
  return true;
}

}  // namespace wet_curly_hair
