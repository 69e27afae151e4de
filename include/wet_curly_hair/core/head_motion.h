// Scripted head motions (still, spin, nod, shake, teleport, linear) as functions of time: the
// offline runner and the head-motion publisher node share them.
#pragma once

#include <string>

#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Scene YAML section `motion`; also `--motion NAME:key=value,...` in the runner.
struct HeadMotionConfig {
  std::string type = "still";   ///< still | spin | nod | shake | teleport | linear
  double rate_hz = 0.5;         ///< spin: revolutions per second.
  double freq_hz = 1.0;         ///< nod, shake: oscillation frequency, Hz.
  double amplitude_rad = 0.35;  ///< nod, shake: peak angle, rad.
  double distance_m = 1.0;      ///< teleport: jump distance along axis, m.
  double speed_m_s = 0.5;       ///< linear: speed along axis, m/s.
  double start_s = 0.0;         ///< motion begins at this time (teleport: the jump instant), s.
  double stop_s = 1e9;          ///< spin, nod, shake, linear stop dead at this time, s.
  Vec3 axis = Vec3::UnitZ();    ///< spin axis / teleport and linear direction (head start frame).
  Pose base;                    ///< head pose at rest (head -> world).
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Parses "NAME[:key=value,...]" (keys are the field names above, axis as axis_x/axis_y/axis_z)
/// into *config, starting from its current values. On failure *config is unchanged.
bool parseMotionSpec(const std::string& spec, HeadMotionConfig* config, std::string* why);

/// Head pose (head -> world) at time t_s.
Pose headPose(const HeadMotionConfig& motion, double t_s);

/// Rigid velocity of the head at time t_s (world frame, about the head origin); forward
/// difference of headPose, exact enough for initial conditions.
Twist headTwist(const HeadMotionConfig& motion, double t_s);

}  // namespace wet_curly_hair
