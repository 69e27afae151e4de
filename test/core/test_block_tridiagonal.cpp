// The implicit integrators' linear solve (block_tridiagonal.h) against a dense solve of the same
// system, in double and in float lanes.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <random>
#include <vector>

#include "wet_curly_hair/core/block_tridiagonal.h"

using namespace wet_curly_hair;

namespace {

/// One strand's system as the integrators build it: edge blocks a I + b u u^T + c w w^T
/// (a, b, c >= 0, edgeImplicitTerms), masses, a few particles with a contact block
/// k n n^T + d (I - n n^T), and a right-hand side.
struct StrandSystem {
  int n = 0;
  Mat3List block, external;
  std::vector<double> mass;
  Vec3List rhs;
};

StrandSystem randomSystem(int n, unsigned seed, bool with_external) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.0, 1.0);
  auto direction = [&] { return Vec3(unit(rng), unit(rng), unit(rng)).normalized(); };
  StrandSystem s;
  s.n = n;
  for (int i = 0; i < n - 1; ++i) {
    // Stiff along the edge, soft across it, as a stretch spring against bending (1e3 : 1).
    const Vec3 u = direction(), w = direction();
    s.block.push_back(1e-3 * positive(rng) * Mat3::Identity() + positive(rng) * u * u.transpose() +
                      0.1 * positive(rng) * w * w.transpose());
  }
  for (int i = 0; i < n; ++i) {
    s.mass.push_back(1e-3 * (0.5 + positive(rng)));
    const Vec3 nrm = direction();
    const bool touching = with_external && i % 5 == 2;
    s.external.push_back(touching ? Mat3(0.3 * positive(rng) * nrm * nrm.transpose() +
                                         0.01 * (Mat3::Identity() - nrm * nrm.transpose()))
                                  : Mat3::Zero());
    s.rhs.push_back(Vec3(unit(rng), unit(rng), unit(rng)));
  }
  return s;
}

/// The assembled system A u = b over u_1 .. u_{n-1} (u_0's term already in rhs_1).
void assemble(const StrandSystem& s, Eigen::MatrixXd* A_out, Eigen::VectorXd* b_out) {
  const int m = 3 * (s.n - 1);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(m, m);
  Eigen::VectorXd b(m);
  for (int i = 1; i < s.n; ++i) {
    const int r = 3 * (i - 1);
    Mat3 d = s.mass[i] * Mat3::Identity() + s.block[i - 1] + s.external[i];
    if (i < s.n - 1) d += s.block[i];
    A.block<3, 3>(r, r) = d;
    if (i > 1) A.block<3, 3>(r, r - 3) = -s.block[i - 1];
    if (i < s.n - 1) A.block<3, 3>(r, r + 3) = -s.block[i];
    b.segment<3>(r) = s.rhs[i];
  }
  *A_out = A;
  *b_out = b;
}

Eigen::VectorXd stack(const std::vector<Vec3>& u) {
  Eigen::VectorXd x(3 * (u.size() - 1));
  for (size_t i = 1; i < u.size(); ++i) x.segment<3>(3 * (i - 1)) = u[i];
  return x;
}

/// u_1 .. u_{n-1} by a dense LU solve with full pivoting.
std::vector<Vec3> denseSolve(const StrandSystem& s) {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  assemble(s, &A, &b);
  const Eigen::VectorXd x = A.fullPivLu().solve(b);
  std::vector<Vec3> u(s.n, Vec3::Zero());
  for (int i = 1; i < s.n; ++i) u[i] = x.segment<3>(3 * (i - 1));
  return u;
}

/// The kernel on W systems side by side in the lanes of S; returns lane l's u.
template <typename S>
std::vector<std::vector<Vec3>> laneSolve(const std::vector<StrandSystem>& systems,
                                         bool with_external) {
  constexpr int W = kLaneWidth<S>;
  const int n = systems[0].n;
  std::vector<M33<S>> block(n), external(n), pivot_inverse(n);
  std::vector<S> mass(n);
  std::vector<V3<S>> rhs(n), u(n);
  for (int l = 0; l < W; ++l) {
    const StrandSystem& s = systems[l];
    for (int i = 0; i < n; ++i) {
      if (i < n - 1) setLane(&block[i], l, s.block[i]);
      setLane(&external[i], l, s.external[i]);
      setLaneValue(&mass[i], l, s.mass[i]);
      setLane(&rhs[i], l, s.rhs[i]);
    }
  }
  solveSymmetricBlockTridiagonal(n, mass.data(), block.data(),
                                 with_external ? external.data() : nullptr, rhs.data(),
                                 pivot_inverse.data(), u.data());
  std::vector<std::vector<Vec3>> out(W, std::vector<Vec3>(n, Vec3::Zero()));
  for (int l = 0; l < W; ++l)
    for (int i = 1; i < n; ++i) out[l][i] = lane(u[i], l);
  return out;
}

/// The largest |u - reference| over the strand, relative to the largest |reference|.
double relativeError(const std::vector<Vec3>& u, const std::vector<Vec3>& reference) {
  double worst = 0.0, scale = 0.0;
  for (size_t i = 1; i < u.size(); ++i) {
    worst = std::max(worst, (u[i] - reference[i]).norm());
    scale = std::max(scale, reference[i].norm());
  }
  return worst / scale;
}

/// The normwise backward error |A u - b| / (|A| |u| + |b|) (infinity norms), in double.
double backwardError(const StrandSystem& s, const std::vector<Vec3>& u) {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  assemble(s, &A, &b);
  const Eigen::VectorXd x = stack(u);
  const double norm_a = A.cwiseAbs().rowwise().sum().maxCoeff();
  return (A * x - b).lpNorm<Eigen::Infinity>() /
         (norm_a * x.lpNorm<Eigen::Infinity>() + b.lpNorm<Eigen::Infinity>());
}

constexpr double kDoubleEpsilon = 0x1p-52, kFloatEpsilon = 0x1p-23;

/// What a backward-stable elimination of N unknowns may leave: the LU bound's 3 N eps, times a
/// growth factor of 4 (no pivoting; the blocks are positive definite, so the pivots stay so).
/// Measured on these systems: up to 130 eps in double and in float. Pivots without the contact
/// blocks leave 1.6e-2; the right-hand side's elimination 1 % short, 7e-6.
double backwardErrorBound(const StrandSystem& s, double eps) {
  return 4.0 * 3.0 * 3 * (s.n - 1) * eps;
}

/// The 2-norm condition number of the assembled system.
double conditionNumber(const StrandSystem& s) {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  assemble(s, &A, &b);
  const Eigen::VectorXd sv = Eigen::JacobiSVD<Eigen::MatrixXd>(A).singularValues();
  return sv(0) / sv(sv.size() - 1);
}

}  // namespace

TEST(BlockTridiagonal, SymmetricInverseReadsTheUpperTriangleAndInverts) {
  Mat3 a;
  a << 4.0, 1.0, -0.5, 1.0, 3.0, 0.25, -0.5, 0.25, 2.0;
  M33<double> upper = toM33(a);
  upper.m[1][0] = upper.m[2][0] = upper.m[2][1] = 1e30;  // never read
  const Mat3 inv = toEigen(inverseSymmetric(upper));
  EXPECT_LT((a * inv - Mat3::Identity()).norm(), 1e-15);
  EXPECT_EQ(inv, inv.transpose());
  EXPECT_LT((inv - a.inverse()).norm(), 1e-15);
}

TEST(BlockTridiagonal, DoubleMatchesADenseSolve) {
  // The shortest strands (one unknown, two, ...), both parities and the usual 32: the first
  // unknown has no neighbour to eliminate and the last no edge past it, whatever n is.
  for (int n : {2, 3, 4, 5, 6, 7, 32, 33})
    for (bool with_external : {false, true})
      for (unsigned seed = 1; seed <= 5; ++seed) {
        const StrandSystem s = randomSystem(n, seed, with_external);
        const std::vector<Vec3> u = laneSolve<double>({s}, with_external)[0];
        EXPECT_LT(backwardError(s, u), backwardErrorBound(s, kDoubleEpsilon))
            << "n " << n << " seed " << seed;
        // Forward: the backward bound times the condition number (2-5e3 here).
        EXPECT_LT(relativeError(u, denseSolve(s)),
                  conditionNumber(s) * backwardErrorBound(s, kDoubleEpsilon))
            << "n " << n << " seed " << seed;
      }
}

TEST(BlockTridiagonal, EveryLaneSolvesItsOwnSystem) {
  for (bool with_external : {false, true}) {
    std::vector<StrandSystem> systems;
    for (int l = 0; l < 8; ++l) systems.push_back(randomSystem(32, 100 + l, with_external));
    const auto in_double4 = laneSolve<LaneDouble4>(
        std::vector<StrandSystem>(systems.begin(), systems.begin() + 4), with_external);
    const auto in_float8 = laneSolve<LaneFloat8>(systems, with_external);
    for (int l = 0; l < 8; ++l) {
      const StrandSystem& s = systems[l];
      if (l < 4) {
        EXPECT_LT(backwardError(s, in_double4[l]), backwardErrorBound(s, kDoubleEpsilon))
            << "lane " << l;
      }
      EXPECT_LT(backwardError(s, in_float8[l]), backwardErrorBound(s, kFloatEpsilon))
          << "lane " << l;
    }
  }
}
