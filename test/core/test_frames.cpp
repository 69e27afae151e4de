// Frames parallel-transported along the smoothed curve (docs/physics.md §2.4, §10.5).
#include <gtest/gtest.h>

#include <cmath>

#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/smoothing.h"

using namespace wet_curly_hair;

namespace {

double orthonormalityError(const Mat3& f) {
  return (f.transpose() * f - Mat3::Identity()).cwiseAbs().maxCoeff() +
         std::abs(f.determinant() - 1.0);
}

void checkFramesAlong(const Vec3List& p, double beta, const char* what) {
  const int n = static_cast<int>(p.size());
  Vec3List d(n - 1);
  Mat3List frames(n - 1);
  smoothDifferences(p.data(), n, beta, d.data());
  const Mat3 root = frameFromTangent(p[1] - p[0], Vec3(0.3, 0.9, 0.1));
  transportFrames(root, d.data(), n - 1, frames.data());
  for (int i = 0; i < n - 1; ++i) {
    EXPECT_LT(orthonormalityError(frames[i]), 1e-9) << what << " frame " << i;
    if (i >= 1 && d[i - 1].norm() > 1e-9) {
      // Each frame's tangent follows the smoothed curve.
      EXPECT_LT((frames[i].col(0) - d[i - 1].normalized()).norm(), 1e-9) << what << " " << i;
    }
  }
}

}  // namespace

TEST(Frames, MinimalRotationMapsAOntoB) {
  const Vec3 dirs[] = {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.3, -0.2, 0.9).normalized(),
                       Vec3(-1, 0, 0), Vec3(1, 1e-9, 0).normalized()};
  for (const Vec3& a : dirs) {
    for (const Vec3& b : dirs) {
      const Mat3 r = minimalRotation(a, b);
      EXPECT_LT((r * a - b).norm(), 1e-12);
      EXPECT_LT(orthonormalityError(r), 1e-12);
    }
  }
  // Antiparallel: a rotation by pi.
  const Vec3 a = Vec3(0.2, 0.3, -0.9).normalized();
  EXPECT_LT((minimalRotation(a, -a) * a + a).norm(), 1e-12);
}

TEST(Frames, TheRotationAppliedIsTheMatrixTimesTheVector) {
  // The transport turns a normal with minimalRotationApplied; the matrix form serves the curl
  // rotations and the bending gradient: one rotation, both forms, the rare branch included
  // (4 of the 8 cosines below -0.99, one of them -1), in double and in float lanes.
  const Vec3 a = Vec3(0.3, -0.2, 0.9).normalized(), x = Vec3(-0.4, 0.8, 0.1);
  const Vec3 bs[] = {a,
                     Vec3(0.5, 0.5, -0.2).normalized(),
                     (-a + Vec3(0.05, 0.08, 0)).normalized(),
                     -a,
                     Vec3(0, 1, 0),
                     Vec3(-0.3, 0.25, -0.9).normalized(),
                     (-a + Vec3(0, 0.1, 0.03)).normalized(),
                     Vec3(1, 0, 0)};
  const V3<LaneFloat8> la = splat3<LaneFloat8>(a), lx = splat3<LaneFloat8>(x);
  V3<LaneFloat8> lb = zero3<LaneFloat8>();
  int rare = 0;
  for (int l = 0; l < 8; ++l) {
    const Vec3& b = bs[l];
    rare += a.dot(b) < kOppositeCosine;
    const Vec3 applied = toEigen(minimalRotationApplied(toV3(a), toV3(b), toV3(x)));
    EXPECT_LT((applied - minimalRotation(a, b) * x).norm(), 1e-15) << "b " << l;
    EXPECT_NEAR(applied.norm(), x.norm(), 1e-15);
    setLane(&lb, l, b);
  }
  EXPECT_EQ(rare, 4);
  const V3<LaneFloat8> in_lanes = minimalRotationApplied(la, lb, lx);
  for (int l = 0; l < 8; ++l)
    EXPECT_LT((lane(in_lanes, l) - minimalRotation(a, bs[l]) * x).norm(), 1e-6) << "lane " << l;
}

TEST(Frames, MinimalRotationLeavesTheCommonPerpendicularAlone) {
  const Vec3 a(1, 0, 0), b = Vec3(1, 1, 0).normalized();
  EXPECT_LT((minimalRotation(a, b) * Vec3::UnitZ() - Vec3::UnitZ()).norm(), 1e-15);
}

TEST(Frames, OrthonormalAlongATightHelix) {
  Vec3List p;
  for (int i = 0; i < 128; ++i) {
    const double t = 1.3 * i;  // 1.3 rad per edge: very tight
    p.push_back(Vec3(0.004 * std::cos(t), 0.004 * std::sin(t), 0.0005 * t));
  }
  checkFramesAlong(p, 1.0, "tight helix, no smoothing");
  checkFramesAlong(p, 0.2, "tight helix, smoothed");
}

TEST(Frames, OrthonormalAlongAStrandThatFoldsBack) {
  Vec3List p;
  for (int i = 0; i < 20; ++i) p.push_back(Vec3(0, 0, 0.01 * i));
  for (int i = 1; i < 20; ++i) p.push_back(Vec3(0.001 * std::min(i, 2), 0, 0.19 - 0.01 * i));
  checkFramesAlong(p, 1.0, "fold, no smoothing");
  checkFramesAlong(p, 0.3, "fold, smoothed");
  // An exact reversal (180 degree turn) as well.
  Vec3List q = {Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, 0), Vec3(0, 0, -1)};
  checkFramesAlong(q, 1.0, "exact reversal");
}

TEST(Frames, RigidRotationRotatesFrames) {
  Vec3List p;
  for (int i = 0; i < 30; ++i)
    p.push_back(Vec3(0.01 * std::cos(0.7 * i), 0.01 * std::sin(0.7 * i), 0.003 * i));
  const Mat3 r = Eigen::AngleAxisd(0.8, Vec3(0.3, 0.5, 0.2).normalized()).toRotationMatrix();
  Vec3List q;
  for (const Vec3& x : p) q.push_back(r * x);
  Vec3List dp(29), dq(29);
  Mat3List fp(29), fq(29);
  smoothDifferences(p.data(), 30, 0.3, dp.data());
  smoothDifferences(q.data(), 30, 0.3, dq.data());
  const Mat3 root = frameFromTangent(p[1] - p[0], Vec3::UnitX());
  transportFrames(root, dp.data(), 29, fp.data());
  transportFrames(r * root, dq.data(), 29, fq.data());
  for (int i = 0; i < 29; ++i) EXPECT_LT((fq[i] - r * fp[i]).norm(), 1e-12) << i;
}
