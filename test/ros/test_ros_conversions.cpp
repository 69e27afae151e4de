// gtest without a master: message definitions and the conversions of the ROS layer.
#include <gtest/gtest.h>
#include <ros/message_traits.h>

#include <cmath>

#include "wet_curly_hair/OctomapCompat.h"
#include "wet_curly_hair/SaturationChange.h"
#include "wet_curly_hair/SetSaturation.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/io/scene.h"
#include "wet_curly_hair/io/scene_setup.h"
#include "wet_curly_hair/ros/conversions.h"
#include "wet_curly_hair/ros/head_motion_publisher.h"
#include "wet_curly_hair/ros/ros_params.h"

namespace wet_curly_hair {
namespace {

TEST(Messages, OctomapCompatHasTheMd5OfOctomapMsgsOctomap) {
  // octomap_msgs/Octomap: Header header, bool binary, string id, float64 resolution, int8[] data
  EXPECT_STREQ(ros::message_traits::md5sum<OctomapCompat>(), "9a45536b45c5e409cd49f04bb2d9999f");
}

HairModel smallModel() {
  io::SceneConfig scene = io::builtinScene();
  scene.groom.strands = 5;
  scene.groom.particles = 7;
  HairModel model;
  std::string why;
  EXPECT_TRUE(io::buildSceneModel(scene, &model, &why)) << why;
  return model;
}

TEST(Conversions, StrandsMessageSizesAndValues) {
  const HairModel model = smallModel();
  Pose head;
  head.translation = Vec3(0.1, 0.2, 1.5);
  HairState state = makeState(model, head, Twist());
  state.saturation[3] = 0.25;
  std_msgs::Header h;
  h.frame_id = "world";
  h.stamp = ros::Time(12, 5);
  Strands m;
  stateToStrandsMsg(model, state, true, h, 7, 2, head, &m);
  EXPECT_EQ(m.strand_offsets.size(), 6u);
  EXPECT_EQ(m.strand_offsets.back(), 35u);
  EXPECT_EQ(m.positions.size(), 105u);
  EXPECT_EQ(m.saturation.size(), 35u);
  EXPECT_EQ(m.wet_positions.size(), 105u);
  EXPECT_EQ(m.step, 7u);
  EXPECT_EQ(m.reset_count, 2u);
  EXPECT_EQ(m.header.stamp, ros::Time(12, 5));
  EXPECT_FLOAT_EQ(m.saturation[3], 0.25f);
  EXPECT_FLOAT_EQ(m.positions[3 * 4 + 2], static_cast<float>(state.position[4].z()));
  EXPECT_DOUBLE_EQ(m.head_pose.position.z, 1.5);
  stateToStrandsMsg(model, state, false, h, 8, 2, head, &m);  // cohesion off: no wet positions
  EXPECT_TRUE(m.wet_positions.empty());
}

TEST(Conversions, MarkerIsOneLineListWithTwoColouredPointsPerEdge) {
  const HairModel model = smallModel();
  HairState state = makeState(model, Pose(), Twist());
  state.saturation.assign(state.saturation.size(), 1.0);
  std_msgs::Header h;
  h.frame_id = "world";
  visualization_msgs::MarkerArray a;
  stateToMarkerArray(model, state, false, h, 0.002, &a);
  ASSERT_EQ(a.markers.size(), 1u);
  const auto& m = a.markers[0];
  EXPECT_EQ(m.type, visualization_msgs::Marker::LINE_LIST);
  EXPECT_EQ(m.points.size(), 2u * (35 - 5));
  EXPECT_EQ(m.colors.size(), m.points.size());
  EXPECT_DOUBLE_EQ(m.points[0].x, state.position[0].x());
  EXPECT_DOUBLE_EQ(m.points[1].x, state.position[1].x());
  float r, g, b;
  saturationColor(1.0, &r, &g, &b);
  EXPECT_FLOAT_EQ(m.colors[0].b, b);
  saturationColor(std::nan(""), &r, &g, &b);  // non-finite shows as dry
  float r0, g0, b0;
  saturationColor(0.0, &r0, &g0, &b0);
  EXPECT_EQ(r, r0);
  EXPECT_GT(b, r - 1.0f);
}

TEST(Conversions, PoseFromTransformNormalisesAndRefusesDegenerate) {
  geometry_msgs::Transform t;
  t.translation.x = 1.0;
  t.rotation.w = 2.0;  // not unit
  Pose p;
  ASSERT_TRUE(poseFromTransform(t, &p));
  EXPECT_DOUBLE_EQ(p.rotation.w(), 1.0);
  EXPECT_DOUBLE_EQ(p.translation.x(), 1.0);
  t.rotation.w = 0.0;
  EXPECT_FALSE(poseFromTransform(t, &p));
  t.rotation.w = 1.0;
  t.translation.y = std::nan("");
  EXPECT_FALSE(poseFromTransform(t, &p));
}

TEST(Conversions, SaturationRequestsMapToCommandsAndBadCodesAreRefused) {
  SetSaturation::Request r;
  r.strands = {1, 4};
  r.root_value = 0.2f;
  r.tip_value = 0.9f;
  r.add = true;
  r.region_type = SetSaturation::Request::REGION_BOX;
  r.region_frame = SetSaturation::Request::FRAME_HEAD;
  r.region_center.x = 0.1;
  r.region_half_extents.x = r.region_half_extents.y = r.region_half_extents.z = 0.3;
  SaturationCommand c;
  std::string why;
  ASSERT_TRUE(saturationCommandFromMsg(r, &c, &why)) << why;
  EXPECT_EQ(c.strands, (std::vector<uint32_t>{1, 4}));
  EXPECT_FLOAT_EQ(c.root_value, 0.2f);
  EXPECT_TRUE(c.add);
  EXPECT_EQ(c.region.kind, SaturationRegion::Kind::kBox);
  EXPECT_TRUE(c.region.in_head_frame);
  EXPECT_DOUBLE_EQ(c.region.half_extents_m.z(), 0.3);
  r.region_type = 9;
  EXPECT_FALSE(saturationCommandFromMsg(r, &c, &why));
  EXPECT_NE(why.find("region_type"), std::string::npos);
  r.region_type = 0;
  r.region_frame = 3;
  EXPECT_FALSE(saturationCommandFromMsg(r, &c, &why));
  EXPECT_NE(why.find("region_frame"), std::string::npos);
  SaturationChange s;  // the scheduled message converts the same way
  s.region_type = SaturationChange::REGION_SPHERE;
  s.region_radius = 0.1;
  ASSERT_TRUE(saturationCommandFromMsg(s, &c, &why)) << why;
  EXPECT_EQ(c.region.kind, SaturationRegion::Kind::kSphere);
}

TEST(RosParams, DottedNamesBecomeNamespaces) {
  EXPECT_EQ(rosParamName("solver.bend.stiffness_n_per_m"), "solver/bend/stiffness_n_per_m");
}

TEST(HeadMotion, ChainComposesMotionsOnTheBase) {
  HeadMotionPublisherConfig c;
  std::string why;
  ASSERT_TRUE(parseMotionChain("nod:freq_hz=0.5,amplitude_rad=0.3", &c.motions, &why)) << why;
  c.base.translation = Vec3(0, 0, 1.5);
  const Pose single = headMotionChainPose(c, 0.7);
  const Pose core = headPose(c.motions[0], 0.7);
  EXPECT_TRUE(single.rotation.isApprox(core.rotation));
  EXPECT_NEAR((single.translation - (core.translation + Vec3(0, 0, 1.5))).norm(), 0.0, 1e-12);
  ASSERT_TRUE(parseMotionChain("shake:freq_hz=1+nod:freq_hz=0.5", &c.motions, &why)) << why;
  EXPECT_EQ(c.motions.size(), 2u);
  EXPECT_FALSE(parseMotionChain("nod:freq_hz=0.5+wobble", &c.motions, &why));
  EXPECT_NE(why.find("wobble"), std::string::npos) << why;
}

}  // namespace
}  // namespace wet_curly_hair
