// Hair-hair contact (Iben et al. 2013 §2.8 of docs/physics.md, A21): penalty springs between
// collision spheres on a pruned subset of the particles, stiffness ramped in on first contact and
// tapered out on release, Coulomb friction between strands. The forces couple strands, so they
// are evaluated once per substep for every strand and added to the strand steps as an external
// force (the documented split of docs/hair_contact.md).
#pragma once

#include <cstdint>

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// The pair force on sphere i from sphere j (f on j is its negative, to the last bit: every term
/// flips sign exactly when i and j swap). d = x_j - x_i; dv = v_j - v_i; contact distance 2 r;
/// k, c the pair's stiffness and damping (already scaled by the ramp), m_eff the reduced mass,
/// h the substep. Zero when the spheres do not touch. Normal part: -(k (2r - |d|) +
/// c (dv . n)) n with n = d / |d|, clamped so it never pulls (a separating pair is not held);
/// tangential part: Coulomb, -min(mu |f_n|, m_eff |dv_t| / h) dv_t / |dv_t|.
Vec3 hairContactPairForce(const Vec3& d, const Vec3& dv, double contact_m, double k, double c,
                          double friction, double m_eff, double h);

/// One step of the ramp variable a of a sphere (docs/hair_contact.md): toward 1 at h / ramp
/// while touching, toward 0 at h / taper otherwise. A pair's stiffness is min(a_i, a_j) K l_i l_j.
double hairContactEngagement(double a, bool touching, double h, double ramp_s, double taper_s);

/// Prunes the spheres (when the model's particle count, radius or sparsity changed since the
/// last call) and resets the engagements. No-op when nothing changed.
void prepareHairContact(const HairModel& model, const HairContactConfig& config,
                        HairContactState* contact);

/// One substep's contact forces, added to state->external_force (which the caller zeroes), and
/// per strand whether any force was applied (contact->strand_touching). Rebuilds the Verlet list
/// when a sphere has moved more than half the skin in the head frame (`head`: head -> world at
/// the substep's start); the result does not depend on the thread count. Returns the touching
/// pairs.
uint64_t computeHairContactForces(const HairModel& model, const HairContactConfig& config, double h,
                                  const Pose& head, int threads, HairState* state);

}  // namespace wet_curly_hair
