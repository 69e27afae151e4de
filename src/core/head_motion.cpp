#include "wet_curly_hair/core/head_motion.h"

#include <cmath>
#include <sstream>

#include "wet_curly_hair/core/config.h"

namespace wet_curly_hair {

bool HeadMotionConfig::validate(const std::string& p, std::string* why) const {
  using namespace config_check;
  if (type != "still" && type != "spin" && type != "nod" && type != "shake" && type != "teleport" &&
      type != "linear") {
    if (why)
      *why = p + "type: '" + type + "' is not one of still, spin, nod, shake, teleport, linear";
    return false;
  }
  if (!finiteInRange(p + "rate_hz", rate_hz, -100.0, 100.0, why) ||
      !finiteInRange(p + "freq_hz", freq_hz, 0.0, 100.0, why) ||
      !finiteInRange(p + "amplitude_rad", amplitude_rad, -M_PI, M_PI, why) ||
      !finiteInRange(p + "distance_m", distance_m, -1e3, 1e3, why) ||
      !finiteInRange(p + "speed_m_s", speed_m_s, -1e3, 1e3, why) ||
      !finiteInRange(p + "start_s", start_s, 0.0, 1e9, why) ||
      !finiteInRange(p + "stop_s", stop_s, 0.0, 1e12, why) || !finiteVec(p + "axis", axis, why))
    return false;
  if (axis.norm() < 1e-9) {
    if (why) *why = p + "axis: must not be the zero vector";
    return false;
  }
  if (!base.isFinite()) {
    if (why) *why = p + "base: pose is not finite";
    return false;
  }
  return true;
}

bool parseMotionSpec(const std::string& spec, HeadMotionConfig* config, std::string* why) {
  HeadMotionConfig c = *config;
  const size_t colon = spec.find(':');
  c.type = spec.substr(0, colon);
  if (colon != std::string::npos) {
    std::stringstream list(spec.substr(colon + 1));
    std::string item;
    while (std::getline(list, item, ',')) {
      const size_t eq = item.find('=');
      if (eq == std::string::npos) {
        if (why) *why = "motion: '" + item + "' is not key=value";
        return false;
      }
      const std::string key = item.substr(0, eq);
      const std::string text = item.substr(eq + 1);
      char* end = nullptr;
      const double value = std::strtod(text.c_str(), &end);
      if (text.empty() || end == nullptr || *end != '\0') {
        if (why) *why = "motion." + key + ": '" + text + "' is not a number";
        return false;
      }
      if (key == "rate_hz")
        c.rate_hz = value;
      else if (key == "freq_hz")
        c.freq_hz = value;
      else if (key == "amplitude_rad")
        c.amplitude_rad = value;
      else if (key == "distance_m")
        c.distance_m = value;
      else if (key == "speed_m_s")
        c.speed_m_s = value;
      else if (key == "start_s")
        c.start_s = value;
      else if (key == "stop_s")
        c.stop_s = value;
      else if (key == "axis_x")
        c.axis.x() = value;
      else if (key == "axis_y")
        c.axis.y() = value;
      else if (key == "axis_z")
        c.axis.z() = value;
      else {
        if (why) *why = "motion." + key + ": unknown key for motion '" + c.type + "'";
        return false;
      }
    }
  }
  if (!c.validate("motion.", why)) return false;
  *config = c;
  return true;
}

Pose headPose(const HeadMotionConfig& m, double t) {
  const double active = std::clamp(t, m.start_s, std::max(m.start_s, m.stop_s)) - m.start_s;
  const Vec3 axis = m.axis.normalized();
  Pose local;
  if (m.type == "spin") {
    local.rotation = Quat(Eigen::AngleAxisd(2.0 * M_PI * m.rate_hz * active, axis));
  } else if (m.type == "nod") {  // pitch about the head's y axis (REP-103: y left)
    local.rotation = Quat(Eigen::AngleAxisd(
        m.amplitude_rad * std::sin(2.0 * M_PI * m.freq_hz * active), Vec3::UnitY()));
  } else if (m.type == "shake") {  // yaw about the head's z axis
    local.rotation = Quat(Eigen::AngleAxisd(
        m.amplitude_rad * std::sin(2.0 * M_PI * m.freq_hz * active), Vec3::UnitZ()));
  } else if (m.type == "teleport") {
    if (t >= m.start_s) local.translation = m.distance_m * axis;
  } else if (m.type == "linear") {
    local.translation = m.speed_m_s * active * axis;
  }
  // Motions are expressed in the base frame: world <- base <- local.
  return m.base * local;
}

Twist headTwist(const HeadMotionConfig& m, double t) {
  // Forward difference: at a motion's start instant the velocity is the one it starts with.
  const double eps = 1e-7;
  const Pose a = headPose(m, t);
  const Pose b = headPose(m, t + eps);
  Twist tw;
  tw.linear = (b.translation - a.translation) / eps;
  const Eigen::AngleAxisd delta(b.rotation * a.rotation.conjugate());
  tw.angular = delta.axis() * delta.angle() / eps;
  if (m.type == "teleport") tw.linear.setZero();  // a jump, not a velocity
  return tw;
}

}  // namespace wet_curly_hair
