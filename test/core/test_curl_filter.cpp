// The curl rotation filter on a block of strands (src/core/curl_filter.cpp): every lane is the
// one-strand definition (Eigen's slerp of M toward helixToHairQuaternion, A8's keep), whatever
// the lanes next to it hold.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "../../src/core/solver_internal.h"
#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/wet_kernels.h"

using namespace wet_curly_hair;

namespace {

HairModel makeModel(int strands) {
  GroomConfig g;
  g.strands = strands;
  g.particles = 8;
  HairModel m;
  std::string why;
  EXPECT_TRUE(buildModel(generateGroom(g, EllipsoidShape()), g.linear_density_kg_per_m, HeadShape(),
                         SolverConfig(), &m, &why))
      << why;
  return m;
}

/// The filter's definition for one strand (what the block computes on each lane).
Quat oneStrand(const HairModel& m, int s, const Vec3& root_to_tip, double f, const Quat& from) {
  const double len = root_to_tip.norm();
  if (!(len > 1e-3 * m.strand_length_m[s])) return from;
  const Quat to = helixToHairQuaternion(m.helix_axis[s], root_to_tip / len);
  return f >= 1.0 ? to : from.slerp(f, to).normalized();
}

double rotationGap(const Quat& a, const Quat& b) {
  return (a.toRotationMatrix() - b.toRotationMatrix()).norm();
}

}  // namespace

TEST(CurlFilter, EveryLaneIsTheOneStrandFilter) {
  const HairModel m = makeModel(40);
  HairState state = makeState(m, Pose(), Twist());
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  const auto random_unit = [&] { return Quat(g(rng), g(rng), g(rng), g(rng)).normalized(); };
  for (double f : {0.04, 0.5, 1.0}) {
    for (int count : {1, 5, 16}) {
      for (int trial = 0; trial < 20; ++trial) {
        int strand[detail::kCurlFilterWidth];
        Vec3 axis[detail::kCurlFilterWidth];
        bool update[detail::kCurlFilterWidth];
        Quat expected[detail::kCurlFilterWidth];
        for (int l = 0; l < count; ++l) {
          strand[l] = (trial * 7 + l * 3) % m.strandCount();  // 16 different strands
          const Vec3 h = m.helix_axis[strand[l]];
          const int kind = (trial + l) % 5;
          // Random axes; nearly opposite to the helix axis (the half-turn patch); near M's
          // target (theta below round-off: the linear blend); too short (A8 keeps M).
          axis[l] = kind == 0   ? Vec3(-h + 1e-3 * Vec3(g(rng), g(rng), g(rng)))
                    : kind == 1 ? Vec3(1e-6 * m.strand_length_m[strand[l]] * Vec3::UnitX())
                                : Vec3(0.1 * Vec3(g(rng), g(rng), g(rng)));
          update[l] = (trial + l) % 4 != 3;
          state.curl_rotation[strand[l]] = random_unit();
          if (kind == 2) {
            const double len = axis[l].norm();
            state.curl_rotation[strand[l]] = helixToHairQuaternion(h, axis[l] / len);
          }
        }
        for (int l = 0; l < count; ++l) {
          const Quat from = state.curl_rotation[strand[l]];
          expected[l] = update[l] ? oneStrand(m, strand[l], axis[l], f, from) : from;
        }
        detail::updateCurlRotations(m, strand, axis, update, count, f, &state);
        for (int l = 0; l < count; ++l) {
          const Quat q = state.curl_rotation[strand[l]];
          EXPECT_NEAR(q.norm(), 1.0, 1e-13);
          EXPECT_LT(rotationGap(q, expected[l]), 1e-12)
              << "f " << f << " count " << count << " trial " << trial << " lane " << l;
        }
      }
    }
  }
}

TEST(CurlFilter, TheSlerpTurnsByTheFractionOfTheAngle) {
  // Analytic: M one turn of phi about n away from its target moves to (1 - f) phi away.
  const HairModel m = makeModel(1);
  HairState state = makeState(m, Pose(), Twist());
  const Vec3 axis = 0.2 * m.helix_axis[0];  // target: the identity (h onto itself)
  const Vec3 n = Vec3(0.3, -0.2, 0.9).normalized();
  for (double phi : {1e-3, 0.2, 1.0, 3.0}) {
    for (double f : {0.04, 0.3}) {
      state.curl_rotation[0] = Quat(Eigen::AngleAxisd(phi, n));
      const int strand = 0;
      const bool update = true;
      detail::updateCurlRotations(m, &strand, &axis, &update, 1, f, &state);
      const Eigen::AngleAxisd left(state.curl_rotation[0]);
      EXPECT_NEAR(left.angle(), (1.0 - f) * phi, 1e-12) << phi << " " << f;
      if (phi > 1e-3) {
        EXPECT_LT((left.axis() - n).norm(), 1e-12);
      }
    }
  }
}
