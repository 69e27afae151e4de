// The linear solve of the implicit integrators (docs/physics.md §9.2, steps 4-5): one strand's
// symmetric block-tridiagonal system, generic over the lane scalar S (lane_math.h), so the
// reference path and every lane layout run this one elimination.
#pragma once

#include "wet_curly_hair/core/lane_math.h"

namespace wet_curly_hair {

/// The inverse of a symmetric 3x3 matrix by cofactors (its adjugate is symmetric too): reads
/// only the upper triangle of `a` and returns a symmetric matrix, 6 cofactors where a general
/// inverse forms 9.
template <typename S>
WCH_INLINE M33<S> inverseSymmetric(const M33<S>& a) {
  const S(&m)[3][3] = a.m;
  const S c00 = m[1][1] * m[2][2] - m[1][2] * m[1][2];
  const S c01 = m[0][2] * m[1][2] - m[0][1] * m[2][2];
  const S c02 = m[0][1] * m[1][2] - m[0][2] * m[1][1];
  const S c11 = m[0][0] * m[2][2] - m[0][2] * m[0][2];
  const S c12 = m[0][1] * m[0][2] - m[0][0] * m[1][2];
  const S c22 = m[0][0] * m[1][1] - m[0][1] * m[0][1];
  const S inv_det = splat<S>(1.0) / (m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02);
  M33<S> r;
  r.m[0][0] = c00 * inv_det;
  r.m[1][1] = c11 * inv_det;
  r.m[2][2] = c22 * inv_det;
  r.m[0][1] = r.m[1][0] = c01 * inv_det;
  r.m[0][2] = r.m[2][0] = c02 * inv_det;
  r.m[1][2] = r.m[2][1] = c12 * inv_det;
  return r;
}

/// *from -= a b on the upper triangle only, for a product known to be symmetric (a symmetric and
/// b = X a with X symmetric: a X a); the lower triangle is not touched.
template <typename S>
WCH_INLINE void subtractSymmetricProduct(const M33<S>& a, const M33<S>& b, M33<S>* from) {
  for (int r = 0; r < 3; ++r)
    for (int c = r; c < 3; ++c)
      from->m[r][c] -= a.m[r][0] * b.m[0][c] + a.m[r][1] * b.m[1][c] + a.m[r][2] * b.m[2][c];
}

/// The upper triangle of `from` into `to`'s, element by element: a loop over the triangle's
/// ragged rows compiled to a string copy (rep movsq) that took a fifth of the elimination.
template <typename S>
WCH_INLINE void copyUpperTriangle(const M33<S>& from, M33<S>* to) {
  to->m[0][0] = from.m[0][0], to->m[0][1] = from.m[0][1], to->m[0][2] = from.m[0][2];
  to->m[1][1] = from.m[1][1], to->m[1][2] = from.m[1][2];
  to->m[2][2] = from.m[2][2];
}
/// `to`'s upper triangle += `from`'s.
template <typename S>
WCH_INLINE void addUpperTriangle(const M33<S>& from, M33<S>* to) {
  to->m[0][0] += from.m[0][0], to->m[0][1] += from.m[0][1], to->m[0][2] += from.m[0][2];
  to->m[1][1] += from.m[1][1], to->m[1][2] += from.m[1][2];
  to->m[2][2] += from.m[2][2];
}

/// Block Thomas for the velocities u_1 .. u_{n-1} of a strand of n particles, u_0 prescribed:
///   (m_i I + G_{i-1} + G_i + E_i) u_i - G_{i-1} u_{i-1} - G_i u_{i+1} = rhs_i,
/// G_i the symmetric coupling block of edge i (i = 0 .. n-2; none past the tip), E_i a particle's
/// own symmetric block (cross-strand contact; `external` null when there is none), the root's
/// term G_0 u_0 already moved into rhs_1 by the caller. The system is symmetric, so each pivot
/// P_i = D_i - G_{i-1} P_{i-1}^-1 G_{i-1} is too: only its upper triangle is formed, and its
/// inverse by inverseSymmetric. Overwrites rhs[1 .. n-1] (the eliminated right-hand side) and
/// pivot_inverse[1 .. n-1]; writes u[1 .. n-1].
template <typename S>
void solveSymmetricBlockTridiagonal(int n, const S* m, const M33<S>* block, const M33<S>* external,
                                    V3<S>* rhs, M33<S>* pivot_inverse, V3<S>* u) {
  for (int i = 1; i < n; ++i) {
    M33<S> pivot;
    copyUpperTriangle(block[i - 1], &pivot);
    if (i < n - 1) addUpperTriangle(block[i], &pivot);
    if (external) addUpperTriangle(external[i], &pivot);
    for (int r = 0; r < 3; ++r) pivot.m[r][r] += m[i];
    if (i > 1) {
      // With W = P_{i-1}^-1 G_{i-1}: P_i -= G_{i-1} W (symmetric), rhs_i += W^T rhs_{i-1}.
      const M33<S> w = pivot_inverse[i - 1] * block[i - 1];
      subtractSymmetricProduct(block[i - 1], w, &pivot);
      rhs[i] += transposeTimes(w, rhs[i - 1]);
    }
    pivot_inverse[i] = inverseSymmetric(pivot);
  }
  u[n - 1] = pivot_inverse[n - 1] * rhs[n - 1];
  for (int i = n - 2; i >= 1; --i) u[i] = pivot_inverse[i] * (rhs[i] + block[i] * u[i + 1]);
}

}  // namespace wet_curly_hair
