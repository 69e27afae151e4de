#include "wet_curly_hair/ros/conversions.h"

#include <algorithm>

namespace wet_curly_hair {

void stateToStrandsMsg(const HairModel& model, const HairState& state, bool with_wet_positions,
                       const std_msgs::Header& header, uint64_t step, uint32_t reset_count,
                       const Pose& head_pose, Strands* msg) {
  const size_t n = state.position.size();
  msg->header = header;
  msg->step = step;
  msg->reset_count = reset_count;
  msg->head_pose = poseToMsg(head_pose);
  msg->strand_offsets.assign(model.strand_offsets.begin(), model.strand_offsets.end());
  msg->positions.resize(3 * n);
  msg->saturation.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Vec3& p = state.position[i];
    msg->positions[3 * i + 0] = static_cast<float>(p.x());
    msg->positions[3 * i + 1] = static_cast<float>(p.y());
    msg->positions[3 * i + 2] = static_cast<float>(p.z());
    msg->saturation[i] = static_cast<float>(state.saturation[i]);
  }
  if (with_wet_positions && state.wet_position.size() == n) {
    msg->wet_positions.resize(3 * n);
    for (size_t i = 0; i < n; ++i) {
      const Vec3& p = state.wet_position[i];
      msg->wet_positions[3 * i + 0] = static_cast<float>(p.x());
      msg->wet_positions[3 * i + 1] = static_cast<float>(p.y());
      msg->wet_positions[3 * i + 2] = static_cast<float>(p.z());
    }
  } else {
    msg->wet_positions.clear();
  }
}

void saturationColor(double s, float* r, float* g, float* b) {
  if (!std::isfinite(s)) s = 0.0;
  s = std::clamp(s, 0.0, 1.0);
  // dry: light tan (0.85, 0.68, 0.45); wet: deep blue (0.10, 0.30, 0.85).
  *r = static_cast<float>(0.85 + (0.10 - 0.85) * s);
  *g = static_cast<float>(0.68 + (0.30 - 0.68) * s);
  *b = static_cast<float>(0.45 + (0.85 - 0.45) * s);
}

void stateToMarkerArray(const HairModel& model, const HairState& state, bool use_wet_positions,
                        const std_msgs::Header& header, double line_width_m,
                        visualization_msgs::MarkerArray* markers) {
  markers->markers.resize(1);
  visualization_msgs::Marker& m = markers->markers[0];
  m.header = header;
  m.ns = "wet_curly_hair/strands";
  m.id = 0;
  m.type = visualization_msgs::Marker::LINE_LIST;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.pose.orientation.x = m.pose.orientation.y = m.pose.orientation.z = 0.0;
  m.pose.position.x = m.pose.position.y = m.pose.position.z = 0.0;
  m.scale.x = line_width_m;
  m.scale.y = m.scale.z = 0.0;
  m.color.r = m.color.g = m.color.b = m.color.a = 1.0f;
  m.lifetime = ros::Duration(0);
  m.frame_locked = false;
  const Vec3List& x = use_wet_positions && state.wet_position.size() == state.position.size()
                          ? state.wet_position
                          : state.position;
  const size_t edges = static_cast<size_t>(model.particleCount() - model.strandCount());
  m.points.resize(2 * edges);
  m.colors.resize(2 * edges);
  size_t k = 0;
  for (int s = 0; s < model.strandCount(); ++s) {
    const int b = model.strandBegin(s), e = b + model.strandSize(s);
    for (int i = b; i + 1 < e; ++i) {
      for (int j = 0; j < 2; ++j, ++k) {
        const int p = i + j;
        m.points[k].x = x[p].x();
        m.points[k].y = x[p].y();
        m.points[k].z = x[p].z();
        std_msgs::ColorRGBA& c = m.colors[k];
        saturationColor(state.saturation[p], &c.r, &c.g, &c.b);
        c.a = 1.0f;
      }
    }
  }
}

geometry_msgs::Pose poseToMsg(const Pose& pose) {
  geometry_msgs::Pose p;
  p.position.x = pose.translation.x();
  p.position.y = pose.translation.y();
  p.position.z = pose.translation.z();
  p.orientation.x = pose.rotation.x();
  p.orientation.y = pose.rotation.y();
  p.orientation.z = pose.rotation.z();
  p.orientation.w = pose.rotation.w();
  return p;
}

bool poseFromTransform(const geometry_msgs::Transform& t, Pose* pose) {
  const Quat q(t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z);
  const Vec3 x(t.translation.x, t.translation.y, t.translation.z);
  const double n = q.norm();
  if (!q.coeffs().allFinite() || !x.allFinite() || !(n > 1e-9)) return false;
  pose->rotation = Quat(q.coeffs() / n);
  pose->translation = x;
  return true;
}

}  // namespace wet_curly_hair
