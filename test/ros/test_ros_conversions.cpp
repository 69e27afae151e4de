// gtest without a master: message definitions and the conversions of the ROS layer.
#include <gtest/gtest.h>
#include <ros/message_traits.h>

#include <array>
#include <cmath>
#include <limits>

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

using Rgb = std::array<float, 3>;

Rgb colorOf(double saturation) {
  Rgb c;
  saturationColor(saturation, &c[0], &c[1], &c[2]);
  return c;
}

HairModel smallModel(int strands = 5, int particles = 7) {
  io::SceneConfig scene = io::builtinScene();
  scene.groom.strands = strands;
  scene.groom.particles = particles;
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

TEST(Conversions, StrandsMessageIsEveryValueRoundedToFloatOnAnyThreadCount) {
  // Each array is converted element by element, split among threads: every coordinate,
  // saturation and display coordinate of every particle, the first and last included, is its
  // double rounded to float, whatever the thread count (and a count above the elements').
  const HairModel model = smallModel(37, 9);
  HairState state = makeState(model, Pose(), Twist());
  const size_t n = state.position.size();
  for (size_t i = 0; i < n; ++i) {
    state.position[i] += Vec3(1e-3 * i, -2e-3 * i, 0.1 / (i + 1));
    state.wet_position[i] = state.position[i] + Vec3(1e-4, 2e-4 * i, -3e-4);
    state.saturation[i] = double(i % 10) / 9.0 + 1e-9;
  }
  for (int threads : {1, 2, 3, 1000}) {
    Strands m;
    stateToStrandsMsg(model, state, true, std_msgs::Header(), 1, 0, Pose(), &m, threads);
    ASSERT_EQ(m.positions.size(), 3 * n);
    ASSERT_EQ(m.wet_positions.size(), 3 * n);
    ASSERT_EQ(m.saturation.size(), n);
    for (size_t i = 0; i < n; ++i) {
      ASSERT_EQ(m.saturation[i], static_cast<float>(state.saturation[i])) << threads << " " << i;
      for (int a = 0; a < 3; ++a) {
        ASSERT_EQ(m.positions[3 * i + a], static_cast<float>(state.position[i][a]))
            << threads << " threads, particle " << i << " axis " << a;
        ASSERT_EQ(m.wet_positions[3 * i + a], static_cast<float>(state.wet_position[i][a]))
            << threads << " threads, particle " << i << " axis " << a;
      }
    }
  }
}

TEST(Conversions, WithNothingDisplayedTheDisplayPositionsAreThePositions) {
  // A display pass with nothing to display (dry hair, cohesion on) leaves wet_position unwritten
  // (HairState::display_is_position): the message's wet_positions and the markers drawn with the
  // display positions are the positions, not the stale list.
  const HairModel model = smallModel();
  HairState state = makeState(model, Pose(), Twist());
  for (Vec3& p : state.position) p += Vec3(0.01, -0.02, 0.03);  // moved since wet_position
  state.display_is_position = true;
  std_msgs::Header h;
  h.frame_id = "world";
  Strands m;
  stateToStrandsMsg(model, state, true, h, 1, 0, Pose(), &m);
  ASSERT_EQ(m.wet_positions.size(), m.positions.size());
  EXPECT_EQ(m.wet_positions, m.positions);
  visualization_msgs::MarkerArray a;
  stateToMarkerArray(model, state, true, h, 0.002, &a);
  ASSERT_EQ(a.markers.size(), 1u);
  EXPECT_DOUBLE_EQ(a.markers[0].points[0].x, state.position[0].x());
  EXPECT_DOUBLE_EQ(a.markers[0].points[1].y, state.position[1].y());
  // Displayed again: the display positions are read.
  state.display_is_position = false;
  stateToStrandsMsg(model, state, true, h, 2, 0, Pose(), &m);
  EXPECT_FLOAT_EQ(m.wet_positions[0], static_cast<float>(state.wet_position[0].x()));
  EXPECT_NE(m.wet_positions[0], m.positions[0]);
}

TEST(Conversions, StrandsMessageSaysWhichStrandsAreGuides) {
  // Every strand simulated: all are guides.
  Strands m;
  const HairModel all = smallModel();
  stateToStrandsMsg(all, makeState(all, Pose(), Twist()), true, std_msgs::Header(), 1, 0, Pose(),
                    &m);
  EXPECT_EQ(m.guide_strands, 5u);
  // One in 3: strands [0, 4) are the guides, the 6 followers are published with them.
  io::SceneConfig scene = io::builtinScene();
  scene.groom.strands = 10;
  scene.groom.particles = 7;
  scene.groom.follow_ratio = 3;
  HairModel model;
  std::string why;
  ASSERT_TRUE(io::buildSceneModel(scene, &model, &why)) << why;
  stateToStrandsMsg(model, makeState(model, Pose(), Twist()), true, std_msgs::Header(), 1, 0,
                    Pose(), &m);
  EXPECT_EQ(m.guide_strands, 4u);
  EXPECT_EQ(m.strand_offsets.size(), 11u);
  EXPECT_EQ(m.positions.size(), 3u * 70u);
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
  // Every point carries the colour of its own particle's saturation.
  state.saturation[1] = 0.0;
  stateToMarkerArray(model, state, false, h, 0.002, &a);
  const Rgb wet = colorOf(1.0), dry = colorOf(0.0);
  const auto& c = a.markers[0].colors;
  EXPECT_EQ(Rgb({c[0].r, c[0].g, c[0].b}), wet);  // edge 0-1: particle 0 wet, particle 1 dry
  EXPECT_EQ(Rgb({c[1].r, c[1].g, c[1].b}), dry);
  EXPECT_EQ(Rgb({c[2].r, c[2].g, c[2].b}), dry);  // edge 1-2 starts at particle 1
  EXPECT_EQ(Rgb({c[3].r, c[3].g, c[3].b}), wet);
  for (const auto& k : c) EXPECT_EQ(k.a, 1.0f);
}

TEST(Conversions, MarkerDrawsEveryKthStrandBeyondItsLimit) {
  const HairModel model = smallModel();  // 5 strands of 7 particles
  const HairState state = makeState(model, Pose(), Twist());
  EXPECT_EQ(markerStrandStride(5, 0), 1);
  EXPECT_EQ(markerStrandStride(5, 5), 1);
  EXPECT_EQ(markerStrandStride(5, 2), 3);  // strands 0 and 3
  EXPECT_EQ(markerStrandStride(10000, 2000), 5);
  visualization_msgs::MarkerArray a;
  stateToMarkerArray(model, state, false, std_msgs::Header(), 0.002, &a,
                     markerStrandStride(model.strandCount(), 2));
  const auto& m = a.markers[0];
  ASSERT_EQ(m.points.size(), 2u * 2u * 6u);
  EXPECT_DOUBLE_EQ(m.points[0].x, state.position[0].x());
  const int third = model.strandBegin(3);
  EXPECT_DOUBLE_EQ(m.points[12].x, state.position[third].x());
  EXPECT_DOUBLE_EQ(m.points[23].z, state.position[third + 6].z());
}

TEST(Conversions, SaturationColourMapRunsFromTanToBlue) {
  // The documented map (conversions.h): dry light tan, fully wet deep blue, a linear blend.
  const Rgb dry = colorOf(0.0), wet = colorOf(1.0);
  EXPECT_NEAR(dry[0], 0.85f, 1e-6f);
  EXPECT_NEAR(dry[1], 0.68f, 1e-6f);
  EXPECT_NEAR(dry[2], 0.45f, 1e-6f);
  EXPECT_NEAR(wet[0], 0.10f, 1e-6f);
  EXPECT_NEAR(wet[1], 0.30f, 1e-6f);
  EXPECT_NEAR(wet[2], 0.85f, 1e-6f);
  // Monotone: red and green fall, blue rises, strictly, at every step of 1/100; the blend is
  // linear.
  Rgb previous = dry;
  for (int k = 1; k <= 100; ++k) {
    const double s = k / 100.0;
    const Rgb now = colorOf(s);
    EXPECT_LT(now[0], previous[0]) << s;
    EXPECT_LT(now[1], previous[1]) << s;
    EXPECT_GT(now[2], previous[2]) << s;
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(now[i], dry[i] + (wet[i] - dry[i]) * s, 1e-6f) << s;
    previous = now;
  }
  // Outside [0, 1] clamped; non-finite is dry, exactly.
  EXPECT_EQ(colorOf(-0.5), dry);
  EXPECT_EQ(colorOf(7.0), wet);
  EXPECT_EQ(colorOf(std::nan("")), dry);
  EXPECT_EQ(colorOf(std::numeric_limits<double>::infinity()), dry);
  EXPECT_EQ(colorOf(-std::numeric_limits<double>::infinity()), dry);
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
  EXPECT_EQ(rosParamName("solver.bend.stiffness_n_m2"), "solver/bend/stiffness_n_m2");
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
