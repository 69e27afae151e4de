// External obstacles' signed distances (obstacles.h): the analytic shapes against their closed
// forms, and the lane form the solver reads against the scalar form, in every lane layout.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "wet_curly_hair/core/obstacles.h"

using namespace wet_curly_hair;

namespace {

AnalyticObstacle sphere(const Vec3& c, double r) {
  AnalyticObstacle o;
  o.shape = AnalyticObstacle::Shape::kSphere;
  o.center_m = c;
  o.radius_m = r;
  return o;
}

/// A sphere, a plane below it, a rotated box beside it and a field holding a second sphere:
/// every kind of obstacle, so the lane form's nearest-obstacle choice is exercised across kinds.
Obstacles mixedScene() {
  Obstacles obstacles;
  obstacles.analytic.push_back(sphere(Vec3(0.1, 0.0, 0.0), 0.05));
  AnalyticObstacle plane;
  plane.shape = AnalyticObstacle::Shape::kPlane;
  plane.center_m = Vec3(0.0, 0.0, -0.2);
  plane.normal = Vec3(0.1, 0.2, 1.0).normalized();
  obstacles.analytic.push_back(plane);
  AnalyticObstacle box;
  box.shape = AnalyticObstacle::Shape::kBox;
  box.center_m = Vec3(-0.1, 0.05, 0.0);
  box.half_extents_m = Vec3(0.03, 0.05, 0.02);
  box.orientation = Quat(Eigen::AngleAxisd(0.4, Vec3(0.3, 1.0, 0.2).normalized()));
  obstacles.analytic.push_back(box);
  auto sdf = std::make_shared<DenseSdf>();
  sdf->voxel_m = 0.01;
  sdf->dims = Eigen::Vector3i(21, 21, 21);
  sdf->origin_m = Vec3(-0.1, -0.1, -0.1);
  sdf->distance_m.resize(21 * 21 * 21);
  for (int k = 0; k < 21; ++k)
    for (int j = 0; j < 21; ++j)
      for (int i = 0; i < 21; ++i)
        sdf->distance_m[sdf->index(i, j, k)] =
            static_cast<float>((sdf->origin_m + 0.01 * Vec3(i, j, k)).norm() - 0.04);
  obstacles.field.sdf = sdf;
  obstacles.field.field_in_world.translation = Vec3(0.0, 0.12, 0.05);
  return obstacles;
}

/// The scalar distance of x to each obstacle of the scene alone, nearest first.
std::vector<double> sortedDistances(const Obstacles& obstacles, const Vec3& x) {
  std::vector<double> d;
  Vec3 n;
  for (const AnalyticObstacle& o : obstacles.analytic) d.push_back(o.distance(x, &n));
  Obstacles field_only;
  field_only.field = obstacles.field;
  d.push_back(field_only.distance(x, &n));
  std::sort(d.begin(), d.end());
  return d;
}

/// The lane form against the scalar form at random points within 0.25 m of the lanes' origin
/// (the block's positions are relative to the head), in the lanes of a changing mask.
template <typename S>
void checkLanesAgainstScalar(const Obstacles& obstacles, const Vec3& origin, double tolerance_m) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.25, 0.25);
  constexpr int kWidth = kLaneWidth<S>;
  for (int trial = 0; trial < 400; ++trial) {
    V3<S> x;
    bool needed[kWidth];
    LaneMask<S> mask{};
    for (int l = 0; l < kWidth; ++l) {
      setLane(&x, l, Vec3(u(rng), u(rng), u(rng)));
      needed[l] = (trial + l) % 3 != 0;
      if constexpr (kWidth == 1)
        mask = needed[l];
      else
        mask[l] = needed[l] ? -1 : 0;
    }
    V3<S> normal;
    const S d = obstacles.distance(x, origin, mask, &normal);
    for (int l = 0; l < kWidth; ++l) {
      if (!needed[l]) continue;
      // The lane's point in world coordinates as the lane holds it.
      const Vec3 world = lane(x, l) + origin;
      Vec3 expected_normal;
      const double expected = obstacles.distance(world, &expected_normal);
      ASSERT_NEAR(laneValue(d, l), expected, tolerance_m) << "trial " << trial << " lane " << l;
      // The nearest obstacle's normal, unless two obstacles are about as near (either may win).
      const std::vector<double> each = sortedDistances(obstacles, world);
      if (each[1] - each[0] < 1e-5) continue;
      EXPECT_LT((lane(normal, l) - expected_normal).norm(), 1e-5) << trial << " lane " << l;
    }
  }
}

}  // namespace

TEST(Obstacles, SphereAndPlaneDistancesAreTheirClosedForms) {
  const AnalyticObstacle s = sphere(Vec3(1.0, 2.0, 3.0), 0.5);
  Vec3 n;
  EXPECT_NEAR(s.distance(Vec3(1.0, 2.0, 4.0), &n), 0.5, 1e-15);
  EXPECT_LT((n - Vec3::UnitZ()).norm(), 1e-15);
  EXPECT_NEAR(s.distance(Vec3(1.3, 2.4, 3.0), &n), -0.0, 1e-15);  // on the surface (3-4-5)
  EXPECT_LT((n - Vec3(0.6, 0.8, 0.0)).norm(), 1e-15);
  EXPECT_NEAR(s.distance(Vec3(1.0, 2.0, 3.0), &n), -0.5, 1e-15);  // the centre: +z by choice
  EXPECT_EQ(n, Vec3::UnitZ());
  AnalyticObstacle p;
  p.shape = AnalyticObstacle::Shape::kPlane;
  p.center_m = Vec3(0.0, 0.0, 1.0);
  p.normal = Vec3(0.0, 0.6, 0.8);
  EXPECT_NEAR(p.distance(Vec3(5.0, 1.0, 1.0), &n), 0.6, 1e-15);
  EXPECT_NEAR(p.distance(Vec3(-2.0, 0.0, 0.0), &n), -0.8, 1e-15);
  EXPECT_EQ(n, p.normal);
}

TEST(Obstacles, TheNearestObstacleWinsAndNoneIsInfinitelyFar) {
  Obstacles obstacles;
  Vec3 n;
  EXPECT_EQ(obstacles.distance(Vec3::Zero(), &n), std::numeric_limits<double>::infinity());
  obstacles.analytic.push_back(sphere(Vec3(1.0, 0.0, 0.0), 0.5));
  obstacles.analytic.push_back(sphere(Vec3(-1.0, 0.0, 0.0), 0.75));
  EXPECT_NEAR(obstacles.distance(Vec3::Zero(), &n), 0.25, 1e-15);  // the second sphere
  EXPECT_LT((n - Vec3(1.0, 0.0, 0.0)).norm(), 1e-15);
}

TEST(Obstacles, LanesAreTheScalarFormInEveryLayout) {
  // Near the world's origin the spheres are read on every lane; 47 m from it, float lanes read
  // them lane by lane, and the plane through its point nearest the origin. Float lanes: a few
  // ulps (6e-8) of the 0.5 m between points and shapes, never of the 47 m.
  const Obstacles scene = mixedScene();
  for (const Vec3& origin : {Vec3(0.02, -0.01, 0.03), Vec3(40.0, -25.0, 3.0)}) {
    checkLanesAgainstScalar<double>(scene, origin, 1e-12);
    checkLanesAgainstScalar<LaneDouble4>(scene, origin, 1e-12);
    checkLanesAgainstScalar<LaneFloat8>(scene, origin, 5e-7);
    checkLanesAgainstScalar<LaneFloat16>(scene, origin, 5e-7);
  }
  // A sphere as large as a planet's patch of ground, its surface 0.1 m below the origin: its
  // centre 50 m away is not held to 5e-7 m in float, so float lanes read it in double.
  Obstacles ground;
  ground.analytic.push_back(sphere(Vec3(1.0, 2.0, -50.0), 50.1));
  const Vec3 origin(1.0, 2.0, 0.2);
  checkLanesAgainstScalar<LaneDouble4>(ground, origin, 1e-12);
  checkLanesAgainstScalar<LaneFloat16>(ground, origin, 5e-7);
}

TEST(Obstacles, ANonFiniteLaneOutsideTheMaskLeavesTheOthersAlone) {
  // A box and the field are read lane by lane: a lane outside the mask holding NaN must not
  // reach the others (nor the spheres' lanes, computed on every lane and selected).
  const Obstacles obstacles = mixedScene();
  V3<LaneFloat8> x;
  LaneMask<LaneFloat8> mask{};
  for (int l = 0; l < 8; ++l) {
    setLane(&x, l, l == 3 ? Vec3::Constant(std::nan("")) : Vec3(0.01 * l, 0.02, -0.05));
    mask[l] = l == 3 ? 0 : -1;
  }
  V3<LaneFloat8> n;
  const LaneFloat8 d = obstacles.distance(x, Vec3::Zero(), mask, &n);
  for (int l = 0; l < 8; ++l) {
    if (l == 3) continue;
    Vec3 expected_n;
    EXPECT_NEAR(d[l], obstacles.distance(lane(x, l), &expected_n), 1e-6) << l;
    EXPECT_TRUE(lane(n, l).allFinite()) << l;
  }
}

TEST(Obstacles, APlaneOnLanesIsTheSamePlaneForANormalUnitOnlyToValidation) {
  // Validation accepts normals unit to 1e-6; the lanes' re-anchored plane must still be the
  // plane n . (x - center) = 0 of the scalar shape (to round-off, 2 m from the lanes' origin).
  AnalyticObstacle plane;
  plane.shape = AnalyticObstacle::Shape::kPlane;
  plane.center_m = Vec3(0.0, 0.0, 1.0);
  plane.normal = Vec3(0.0, 0.0, 1.0 + 9e-7);
  Obstacles obstacles;
  obstacles.analytic.push_back(plane);
  const Vec3 origin(40.0, -25.0, 3.0);
  V3<LaneDouble4> x;
  for (int l = 0; l < 4; ++l) setLane(&x, l, Vec3(0.1 * l, 0.2, 0.5 - 0.3 * l));
  V3<LaneDouble4> n;
  const LaneDouble4 d = obstacles.distance(x, origin, LaneMask<LaneDouble4>{-1, -1, -1, -1}, &n);
  for (int l = 0; l < 4; ++l) {
    Vec3 expected_n;
    EXPECT_NEAR(d[l], plane.distance(lane(x, l) + origin, &expected_n), 1e-14) << l;
  }
}
