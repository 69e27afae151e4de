#include "wet_curly_hair/core/state.h"

namespace wet_curly_hair {

void StrandScratch::resize(int n) {
  force.assign(n, Vec3::Zero());
  smooth_bend.assign(n, Vec3::Zero());
  smooth_core.assign(n, Vec3::Zero());
  smooth_vel.assign(n, Vec3::Zero());
  frame.assign(n, Mat3::Identity());
  target.assign(n, Vec3::Zero());
}

void resetState(const HairModel& model, const Pose& head_pose, const Twist& head_twist,
                HairState* state) {
  for (int i = 0; i < model.particleCount(); ++i) {
    state->position[i] = head_pose.apply(model.rest_position_head[i]);
    state->velocity[i] = head_twist.velocityAt(state->position[i], head_pose.translation);
  }
  state->last_good_position = state->position;
  state->last_good_velocity = state->velocity;
}

HairState makeState(const HairModel& model, const Pose& head_pose, const Twist& head_twist) {
  HairState state;
  const int n = model.particleCount();
  state.position.assign(n, Vec3::Zero());
  state.velocity.assign(n, Vec3::Zero());
  state.saturation.assign(n, 0.0);
  state.scratch.resize(model.max_strand_size);
  resetState(model, head_pose, head_twist, &state);
  return state;
}

}  // namespace wet_curly_hair
