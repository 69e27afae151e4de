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
  c = GroomConfig();
  c.guides = "farthest";
  EXPECT_FALSE(c.validate("groom.", &why));
  EXPECT_NE(why.find("groom.guides: 'farthest' is not one of sampled, first"), std::string::npos)
      << why;
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

TEST(Groom, NearestEllipsoidPointOnASphereIsRadial) {
  EllipsoidShape sphere;
  sphere.center_m = Vec3(0.01, -0.02, 0.03);
  sphere.radii_m = Vec3::Constant(0.1);
  for (const Vec3& d : {Vec3(1, 0, 0), Vec3(0.3, -0.5, 0.8), Vec3(-0.2, 0.1, -1.0)}) {
    for (double k : {0.2, 0.9, 1.0, 1.3, 5.0}) {
      const Vec3 x = sphere.center_m + 0.1 * k * d.normalized();
      const Vec3 p = nearestEllipsoidPoint(sphere, x);
      EXPECT_LT((p - (sphere.center_m + 0.1 * d.normalized())).norm(), 1e-15 + 1e-13 * k)
          << "k " << k;
    }
  }
  // The centre, where every direction is nearest: a surface point all the same.
  EXPECT_NEAR((nearestEllipsoidPoint(sphere, sphere.center_m) - sphere.center_m).norm(), 0.1,
              1e-15);
}

TEST(Groom, NearestEllipsoidPointIsNoFartherThanAnySampledSurfacePoint) {
  // The head's ellipsoid, points 3 cm inside to 3 cm outside: the answer lies on the surface and
  // is at least as near as the nearest of 720 x 360 surface points sampled by angle (an
  // independent reference that is never nearer than the truth).
  EllipsoidShape head;
  head.center_m = Vec3(0.0, 0.005, 0.01);
  const int nu = 720, nv = 360;
  Vec3List surface;
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double v = M_PI * j / nv, u = 2.0 * M_PI * i / nu;
      const Vec3 unit(std::sin(v) * std::cos(u), std::sin(v) * std::sin(u), std::cos(v));
      surface.push_back(head.center_m + head.radii_m.cwiseProduct(unit));
    }
  const Vec3 dirs[] = {Vec3(1, 0.2, 0.4), Vec3(-0.3, 0.9, 0.1), Vec3(0.1, -0.2, 1.0),
                       Vec3(-1, -1, -0.5), Vec3(0.05, 1.0, -0.02)};
  int checked = 0;
  for (const Vec3& d : dirs) {
    const Vec3 on = nearestEllipsoidPoint(head, head.center_m + d);  // a surface point
    const Vec3 n =
        (on - head.center_m).cwiseQuotient(head.radii_m.cwiseProduct(head.radii_m)).normalized();
    for (double offset : {-0.03, -0.01, -0.002, 0.0, 0.004, 0.03}) {
      const Vec3 x = on + offset * n;
      const Vec3 p = nearestEllipsoidPoint(head, x);
      EXPECT_NEAR((p - head.center_m).cwiseQuotient(head.radii_m).norm(), 1.0, 1e-12);
      double sampled = INFINITY;
      for (const Vec3& q : surface) sampled = std::min(sampled, (q - x).norm());
      EXPECT_LE((p - x).norm(), sampled + 1e-12) << "offset " << offset;
      // Along the normal of a convex surface, the point the normal starts from is the nearest
      // (outside always; inside while the offset stays below the curvature radius, 4 cm here).
      EXPECT_NEAR((p - x).norm(), std::abs(offset), 1e-9) << "offset " << offset;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 30);
}

namespace {

/// A generated groom of `strands` x `particles` on the default head.
Groom generatedGroom(int strands, int particles) {
  GroomConfig c;
  c.strands = strands;
  c.particles = particles;
  return generateGroom(c, EllipsoidShape());
}

}  // namespace

TEST(Groom, RootsOnTheScalpMoveEachStrandRigidly) {
  const EllipsoidShape head;
  Groom g = generatedGroom(6, 10);
  // Strand 0 sunk 1 cm into the head along its normal, strand 1 lifted 2 cm off it, strand 2
  // shifted sideways: the others stay where they are.
  const Vec3 moves[3] = {-0.01 * g.root_normals[0], 0.02 * g.root_normals[1],
                         Vec3(0.0, 0.003, -0.001)};
  const Groom authored = g;
  for (int s = 0; s < 3; ++s)
    for (uint32_t i = g.strand_offsets[s]; i < g.strand_offsets[s + 1]; ++i)
      g.points[i] += moves[s];
  Groom placed_groom = g;
  const ScalpPlacement placed = placeRootsOnScalp(head, &placed_groom);
  EXPECT_EQ(placed.strands_moved, 3);
  EXPECT_NEAR(placed.largest_move_m, 0.02, 1e-12);
  EXPECT_EQ(placed.particles_inside, 0);
  std::string why;
  ASSERT_TRUE(placed_groom.validate(&why)) << why;
  for (int s = 0; s < g.strandCount(); ++s) {
    const uint32_t b = g.strand_offsets[s];
    Vec3 n;
    EXPECT_NEAR(ellipsoidDistance(head, placed_groom.points[b], &n), 0.0, 1e-12);
    EXPECT_LT((placed_groom.root_normals[s] - n).norm(), 1e-12);
    for (uint32_t i = b; i < g.strand_offsets[s + 1]; ++i) {
      // The shape is kept: every point relative to its root as authored.
      EXPECT_LT(
          ((placed_groom.points[i] - placed_groom.points[b]) - (g.points[i] - g.points[b])).norm(),
          1e-15);
      // The sunk and lifted strands go back along their normals to where they were generated.
      if (s != 2) {
        EXPECT_LT((placed_groom.points[i] - authored.points[i]).norm(), 1e-12);
      }
    }
  }
  // A strand lying along the scalp, sunk into it, keeps particles inside: counted, not moved.
  Groom flat;
  flat.points = {Vec3(0.0, 0.0, 0.10), Vec3(0.01, 0.0, 0.1095), Vec3(0.06, 0.0, 0.075)};
  flat.strand_offsets = {0, 3};
  flat.root_normals = {Vec3::UnitZ()};
  const ScalpPlacement on_flat = placeRootsOnScalp(head, &flat);
  EXPECT_EQ(on_flat.strands_moved, 1);
  EXPECT_NEAR(on_flat.largest_move_m, 0.01, 1e-12);
  EXPECT_EQ(on_flat.particles_inside, 1);  // (0.01, 0, 0.1195) is outside, (0.06, 0, 0.085) in
}

TEST(Groom, RootsInsideCountsTheRootsDeeperThanTheTolerance) {
  const EllipsoidShape head;
  Groom g = generatedGroom(4, 6);
  EXPECT_EQ(rootsInside(head, g, 1e-4).count, 0) << "generated roots lie on the surface";
  // Strand 0 sunk 1 cm, strand 1 by 0.05 mm (within the tolerance), strand 2 lifted 1 cm.
  const double moves[3] = {-0.01, -0.00005, 0.01};
  for (int s = 0; s < 3; ++s)
    for (uint32_t i = g.strand_offsets[s]; i < g.strand_offsets[s + 1]; ++i)
      g.points[i] += moves[s] * g.root_normals[s];
  const RootsInside inside = rootsInside(head, g, 1e-4);
  EXPECT_EQ(inside.count, 1);
  EXPECT_NEAR(inside.deepest_m, 0.01, 1e-12);
  EXPECT_EQ(rootsInside(head, g, 1e-6).count, 2);
}
