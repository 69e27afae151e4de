#include "wet_curly_hair/ros/conversions.h"

#include <algorithm>
#include <unordered_set>

namespace wet_curly_hair {

namespace {

/// out[k] = float(in[k]) for k in [0, count), on `threads` threads: the frame's conversion reads
/// 18 MB of doubles and writes 9 MB of floats at 10,000 strands, bound by memory, which one core
/// does not saturate on the 2-core machines measured (docs/ros.md).
/// A plain loop on one thread: libgomp allocates a team for every parallel region.
void toFloats(const double* __restrict in, size_t count, int threads, float* __restrict out) {
  const int64_t n = static_cast<int64_t>(count);
  if (threads <= 1) {
    for (int64_t k = 0; k < n; ++k) out[k] = static_cast<float>(in[k]);
    return;
  }
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int64_t k = 0; k < n; ++k) out[k] = static_cast<float>(in[k]);
}

/// The 3 n doubles of a Vec3List end to end (Eigen's Vector3d has no padding).
const double* coordinates(const Vec3List& v) { return v.empty() ? nullptr : v.data()->data(); }
static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");

}  // namespace

void stateToStrandsMsg(const HairModel& model, const HairState& state, bool with_wet_positions,
                       const std_msgs::Header& header, uint64_t step, uint32_t reset_count,
                       const Pose& head_pose, Strands* msg, int threads) {
  const size_t n = state.position.size();
  msg->header = header;
  msg->step = step;
  msg->reset_count = reset_count;
  msg->head_pose = poseToMsg(head_pose);
  msg->strand_offsets.assign(model.strand_offsets.begin(), model.strand_offsets.end());
  msg->guide_strands = static_cast<uint32_t>(model.simulatedStrandCount());
  msg->positions.resize(3 * n);
  msg->saturation.resize(n);
  toFloats(coordinates(state.position), 3 * n, threads, msg->positions.data());
  toFloats(state.saturation.data(), n, threads, msg->saturation.data());
  if (with_wet_positions && state.wet_position.size() == n) {
    msg->wet_positions.resize(3 * n);
    toFloats(coordinates(displayPositions(state)), 3 * n, threads, msg->wet_positions.data());
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

int markerStrandStride(int strands, int max_strands) {
  if (max_strands <= 0 || strands <= max_strands) return 1;
  return (strands + max_strands - 1) / max_strands;
}

void stateToMarkerArray(const HairModel& model, const HairState& state, bool use_wet_positions,
                        const std_msgs::Header& header, double line_width_m,
                        visualization_msgs::MarkerArray* markers, int strand_stride) {
  strand_stride = std::max(1, strand_stride);
  markers->markers.resize(1);
  visualization_msgs::Marker& m = markers->markers[0];
  m.header = header;
  m.ns = kStrandsMarkerNs;
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
                          ? displayPositions(state)
                          : state.position;
  size_t edges = 0;
  for (int s = 0; s < model.strandCount(); s += strand_stride)
    edges += static_cast<size_t>(model.strandSize(s) - 1);
  m.points.resize(2 * edges);
  m.colors.resize(2 * edges);
  size_t k = 0;
  for (int s = 0; s < model.strandCount(); s += strand_stride) {
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

namespace {

visualization_msgs::Marker solidMarker(const std_msgs::Header& header, const char* ns, int32_t id,
                                       int32_t type, float r, float g, float b, float a) {
  visualization_msgs::Marker m;
  m.header = header;
  m.ns = ns;
  m.id = id;
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.color.r = r;
  m.color.g = g;
  m.color.b = b;
  m.color.a = a;
  return m;
}

void setScale(const Vec3& s, visualization_msgs::Marker* m) {
  m->scale.x = s.x();
  m->scale.y = s.y();
  m->scale.z = s.z();
}

// Head: a light grey, far from the tan and blue of the hair's saturation colours.
constexpr float kHeadRgba[4] = {0.78f, 0.78f, 0.80f, 1.0f};
// Obstacles: translucent green, so the hair behind and inside them stays visible.
constexpr float kObstacleRgba[4] = {0.35f, 0.70f, 0.40f, 0.6f};
constexpr float kFieldRgba[4] = {0.35f, 0.60f, 0.35f, 1.0f};

}  // namespace

void appendHeadMarkers(const HeadShape& head, const Pose& head_pose, const std_msgs::Header& header,
                       visualization_msgs::MarkerArray* markers) {
  const float* c = kHeadRgba;
  visualization_msgs::Marker e = solidMarker(
      header, kHeadMarkerNs, 0, visualization_msgs::Marker::SPHERE, c[0], c[1], c[2], c[3]);
  Pose at;
  at.translation = head_pose.translation + head_pose.rotation * head.ellipsoid.center_m;
  at.rotation = head_pose.rotation;
  e.pose = poseToMsg(at);
  setScale(2.0 * head.ellipsoid.radii_m, &e);
  markers->markers.push_back(e);
  int32_t id = 1;
  for (const CapsuleShape& cap : head.capsules) {
    const Vec3 a = head_pose.translation + head_pose.rotation * cap.a_m;
    const Vec3 b = head_pose.translation + head_pose.rotation * cap.b_m;
    const double d = 2.0 * cap.radius_m;
    // RViz's CYLINDER has its axis along the marker's z.
    visualization_msgs::Marker body = solidMarker(
        header, kHeadMarkerNs, id++, visualization_msgs::Marker::CYLINDER, c[0], c[1], c[2], c[3]);
    Pose mid;
    mid.translation = 0.5 * (a + b);
    const Vec3 axis = b - a;
    mid.rotation =
        axis.norm() > 0.0 ? Quat::FromTwoVectors(Vec3::UnitZ(), axis) : head_pose.rotation;
    body.pose = poseToMsg(mid);
    setScale(Vec3(d, d, axis.norm()), &body);
    markers->markers.push_back(body);
    for (const Vec3& end : {a, b}) {
      visualization_msgs::Marker cap_end = solidMarker(
          header, kHeadMarkerNs, id++, visualization_msgs::Marker::SPHERE, c[0], c[1], c[2], c[3]);
      Pose p;
      p.translation = end;
      cap_end.pose = poseToMsg(p);
      setScale(Vec3::Constant(d), &cap_end);
      markers->markers.push_back(cap_end);
    }
  }
}

void appendObstacleMarkers(const std::vector<AnalyticObstacle>& obstacles, const Vec3& near_m,
                           double plane_size_m, const std_msgs::Header& header,
                           visualization_msgs::MarkerArray* markers) {
  const float* c = kObstacleRgba;
  for (size_t k = 0; k < obstacles.size(); ++k) {
    const AnalyticObstacle& o = obstacles[k];
    visualization_msgs::Marker m =
        solidMarker(header, kObstacleMarkerNs, static_cast<int32_t>(k),
                    visualization_msgs::Marker::CUBE, c[0], c[1], c[2], c[3]);
    Pose p;
    switch (o.shape) {
      case AnalyticObstacle::Shape::kSphere:
        m.type = visualization_msgs::Marker::SPHERE;
        p.translation = o.center_m;
        setScale(Vec3::Constant(2.0 * o.radius_m), &m);
        break;
      case AnalyticObstacle::Shape::kBox:
        p.translation = o.center_m;
        p.rotation = o.orientation;
        setScale(2.0 * o.half_extents_m, &m);
        break;
      case AnalyticObstacle::Shape::kPlane: {
        const Vec3 n = o.normal.normalized();
        // Thickness on the obstacle side, so that the drawn top face is the plane itself.
        const double thickness = 0.002;
        p.translation = near_m - (near_m - o.center_m).dot(n) * n - 0.5 * thickness * n;
        p.rotation = Quat::FromTwoVectors(Vec3::UnitZ(), n);
        setScale(Vec3(plane_size_m, plane_size_m, thickness), &m);
        break;
      }
    }
    m.pose = poseToMsg(p);
    markers->markers.push_back(m);
  }
}

namespace {

/// Voxels of the field at or below zero with a face neighbour above zero. Outside the grid counts
/// as free: past its box the solver's field grows like the distance to the box, so an obstacle
/// the box cuts ends about at the cut, and the cut face is where the hair meets it.
std::vector<Eigen::Vector3i> surfaceVoxels(const DenseSdf& sdf) {
  std::vector<Eigen::Vector3i> out;
  const Eigen::Vector3i& d = sdf.dims;
  auto freeAt = [&](int i, int j, int k) {
    if (i < 0 || j < 0 || k < 0 || i >= d.x() || j >= d.y() || k >= d.z()) return true;
    return sdf.distance_m[sdf.index(i, j, k)] > 0.0f;
  };
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        if (!(sdf.distance_m[sdf.index(i, j, k)] <= 0.0f)) continue;
        if (freeAt(i - 1, j, k) || freeAt(i + 1, j, k) || freeAt(i, j - 1, k) ||
            freeAt(i, j + 1, k) || freeAt(i, j, k - 1) || freeAt(i, j, k + 1))
          out.emplace_back(i, j, k);
      }
  return out;
}

/// The distinct blocks of edge `block` voxels that hold the given voxels.
std::vector<Eigen::Vector3i> mergeIntoBlocks(const std::vector<Eigen::Vector3i>& voxels,
                                             int block) {
  std::unordered_set<uint64_t> seen;
  std::vector<Eigen::Vector3i> out;
  for (const Eigen::Vector3i& v : voxels) {
    const Eigen::Vector3i b = v / block;  // voxel indices are non-negative
    const uint64_t key = (static_cast<uint64_t>(b.x()) << 42) |
                         (static_cast<uint64_t>(b.y()) << 21) | static_cast<uint64_t>(b.z());
    if (seen.insert(key).second) out.push_back(b);
  }
  return out;
}

}  // namespace

int obstacleFieldMarker(const ObstacleField& field, size_t max_cubes,
                        const std_msgs::Header& header, visualization_msgs::Marker* marker) {
  const float* c = kFieldRgba;
  *marker = solidMarker(header, kObstacleFieldMarkerNs, 0, visualization_msgs::Marker::CUBE_LIST,
                        c[0], c[1], c[2], c[3]);
  if (!field.sdf || field.sdf->empty() || max_cubes == 0) return 0;
  const DenseSdf& sdf = *field.sdf;
  const std::vector<Eigen::Vector3i> surface = surfaceVoxels(sdf);
  std::vector<Eigen::Vector3i> cells = surface;
  int block = 1;
  while (cells.size() > max_cubes) {
    // A surface's block count falls roughly as 1/k^2: start from that guess, then step up.
    const int guess = static_cast<int>(std::ceil(
        block * std::sqrt(static_cast<double>(cells.size()) / static_cast<double>(max_cubes))));
    block = std::max(block + 1, guess);
    cells = mergeIntoBlocks(surface, block);
  }
  marker->pose = poseToMsg(field.field_in_world);
  setScale(Vec3::Constant(block * sdf.voxel_m), marker);
  marker->points.resize(cells.size());
  // A block's centre: origin_m is the centre of voxel 0, so block b spans voxel centres
  // b * k ... b * k + k - 1.
  const double offset = 0.5 * (block - 1);
  for (size_t n = 0; n < cells.size(); ++n) {
    const Vec3 x =
        sdf.origin_m + sdf.voxel_m * (cells[n].cast<double>() * block + Vec3::Constant(offset));
    marker->points[n].x = x.x();
    marker->points[n].y = x.y();
    marker->points[n].z = x.z();
  }
  return block;
}

void deleteVanishedMarkers(std::set<std::pair<std::string, int32_t>>* published,
                           visualization_msgs::MarkerArray* markers) {
  std::set<std::pair<std::string, int32_t>> now;
  for (const visualization_msgs::Marker& m : markers->markers) now.emplace(m.ns, m.id);
  for (const auto& key : *published) {
    if (now.count(key)) continue;
    visualization_msgs::Marker del;
    del.header = markers->markers.empty() ? std_msgs::Header() : markers->markers[0].header;
    del.ns = key.first;
    del.id = key.second;
    del.action = visualization_msgs::Marker::DELETE;
    del.pose.orientation.w = 1.0;
    markers->markers.push_back(del);
  }
  *published = std::move(now);
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
