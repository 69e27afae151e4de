// The groom generator (scalp patch on an ellipsoid head; curly or straight strands).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/head_collider.h"

using namespace wet_curly_hair;

TEST(Groom, CountsEdgesAndRoots) {
  GroomConfig c;
  c.strands = 50;
  c.particles = 24;
  EllipsoidShape head;
  const Groom g = generateGroom(c, head);
  std::string why;
  ASSERT_TRUE(g.validate(&why)) << why;
  ASSERT_EQ(g.strandCount(), 50);
  ASSERT_EQ(g.particleCount(), 50 * 24);
  for (int s = 0; s < g.strandCount(); ++s) {
    const int b = g.strand_offsets[s];
    Vec3 n;
    EXPECT_NEAR(ellipsoidDistance(head, g.points[b], &n), 0.0, 1e-12) << "root on the scalp";
    EXPECT_LT((n - g.root_normals[s]).norm(), 1e-9);
    double length = 0.0, first = (g.points[b + 1] - g.points[b]).norm();
    for (int i = b; i + 1 < b + 24; ++i) {
      const double e = (g.points[i + 1] - g.points[i]).norm();
      EXPECT_NEAR(e, first, 1e-9 * first) << "equal edges, strand " << s;
      length += e;
    }
    EXPECT_NEAR(length, c.length_m, c.jitter * c.length_m + 1e-12);
    // Every non-root particle starts outside the head (the strand leaves along the normal).
    for (int i = b + 1; i < b + 24; ++i) EXPECT_GT(ellipsoidDistance(head, g.points[i], &n), 0.0);
  }
}

TEST(Groom, IsDeterministicAndSeeded) {
  GroomConfig c;
  c.strands = 10;
  EllipsoidShape head;
  const Groom a = generateGroom(c, head), b = generateGroom(c, head);
  for (int i = 0; i < a.particleCount(); ++i) EXPECT_EQ(a.points[i], b.points[i]);
  c.seed = 2;
  const Groom d = generateGroom(c, head);
  EXPECT_NE(a.points[5], d.points[5]);
}

TEST(Groom, StraightWhenRadiusIsZero) {
  GroomConfig c;
  c.strands = 5;
  c.curl_radius_m = 0.0;
  EllipsoidShape head;
  const Groom g = generateGroom(c, head);
  for (int s = 0; s < 5; ++s) {
    const int b = g.strand_offsets[s];
    const Vec3 dir = (g.points[b + 1] - g.points[b]).normalized();
    EXPECT_LT((dir - g.root_normals[s]).norm(), 1e-12);
    for (int i = b; i + 1 < static_cast<int>(g.strand_offsets[s + 1]); ++i)
      EXPECT_LT(((g.points[i + 1] - g.points[i]).normalized() - dir).norm(), 1e-12);
  }
}

TEST(Groom, CurlRadiusAndPitchAreWhatWasAskedFor) {
  GroomConfig c;
  c.strands = 1;
  c.particles = 120;
  c.length_m = 0.6;
  c.jitter = 0.0;
  c.curl_radius_m = 0.01;
  c.curl_pitch_m = 0.02;
  EllipsoidShape head;
  const Groom g = generateGroom(c, head);
  const Vec3 n = g.root_normals[0];
  // Past the ramp, the distance to the helix axis is the radius.
  const Vec3 root = g.points[0];
  Vec3 axis_point_sum = Vec3::Zero();
  for (int i = 40; i < 120; ++i) axis_point_sum += g.points[i] - n * n.dot(g.points[i] - root);
  const Vec3 centre = axis_point_sum / 80.0;
  for (int i = 40; i < 120; ++i) {
    const Vec3 q = g.points[i] - n * n.dot(g.points[i] - root);
    EXPECT_NEAR((q - centre).norm(), 0.01, 5e-4);
  }
  // Rise: arc length per turn sqrt((2 pi r)^2 + p^2); total rise = length * p / that.
  const double per_turn = std::hypot(2 * M_PI * 0.01, 0.02);
  EXPECT_NEAR(n.dot(g.points[119] - root), 0.6 * 0.02 / per_turn, 0.01);
}

TEST(Groom, EveryEdgeIsTheStrandLengthOverItsEdges) {
  // Without jitter every strand is length_m long: each particle is placed on the curve at
  // exactly length_m / (particles - 1) from the one before, a root of the chord's equation.
  GroomConfig c;
  c.strands = 40;
  c.particles = 64;
  c.jitter = 0.0;
  EllipsoidShape head;
  for (double radius : {0.002, 0.01, 0.03}) {
    c.curl_radius_m = radius;
    const Groom g = generateGroom(c, head);
    const double edge = c.length_m / (c.particles - 1);
    double worst = 0.0;
    for (size_t i = 0; i + 1 < g.points.size(); ++i) {
      if ((i + 1) % c.particles == 0) continue;  // the next strand's root
      worst = std::max(worst, std::abs((g.points[i + 1] - g.points[i]).norm() - edge) / edge);
    }
    EXPECT_LT(worst, 1e-12) << "curl radius " << radius;
  }
}

TEST(Groom, ConfigRefusesBadValuesByName) {
  std::string why;
  GroomConfig c;
  c.particles = 0;
  EXPECT_FALSE(c.validate("groom.", &why));
  EXPECT_NE(why.find("groom.particles"), std::string::npos);
  c = GroomConfig();
  c.length_m = std::nan("");
  EXPECT_FALSE(c.validate("groom.", &why));
  EXPECT_NE(why.find("groom.length_m"), std::string::npos);
  c = GroomConfig();
  c.curl_pitch_m = 0.0;
  EXPECT_FALSE(c.validate("groom.", &why));
  EXPECT_NE(why.find("groom.curl_pitch_m"), std::string::npos);
}

TEST(Groom, HelixAngleStepGivesTheChord) {
  for (double r : {0.005, 0.01, 0.02}) {
    for (double p : {0.0, 0.01, 0.05}) {
      const double dt = helixAngleStepForChord(r, p, 0.008);
      const double chord =
          std::sqrt(4 * r * r * std::pow(std::sin(dt / 2), 2) + std::pow(p / (2 * M_PI) * dt, 2));
      if (dt < M_PI) {
        EXPECT_NEAR(chord, 0.008, 1e-12);
      }
    }
  }
}
