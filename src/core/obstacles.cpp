#include "wet_curly_hair/core/obstacles.h"

#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <sstream>

#include "wet_curly_hair/core/config.h"

namespace wet_curly_hair {

double AnalyticObstacle::distance(const Vec3& x, Vec3* n) const {
  switch (shape) {
    case Shape::kSphere: {
      V3<double> nv;
      const double d = sphereDistance(toV3(center_m), radius_m, toV3(x), &nv);
      *n = toEigen(nv);
      return d;
    }
    case Shape::kPlane: {
      V3<double> nv;
      const double d = planeDistance(toV3(center_m), toV3(normal), toV3(x), &nv);
      *n = toEigen(nv);
      return d;
    }
    case Shape::kBox: {
      // Exact box distance in the box frame, normal back in the world.
      const Vec3 p = orientation.conjugate() * (x - center_m);
      const Vec3 q = p.cwiseAbs() - half_extents_m;
      const Vec3 outside = q.cwiseMax(0.0);
      const double out_len = outside.norm();
      Vec3 local;
      double d;
      if (out_len > 0.0) {
        local = outside.cwiseProduct(p.cwiseSign()) / out_len;
        d = out_len;
      } else {  // inside: the nearest face
        int axis = 0;
        q.maxCoeff(&axis);
        local = Vec3::Zero();
        local[axis] = p[axis] >= 0.0 ? 1.0 : -1.0;
        d = q[axis];
      }
      *n = orientation * local;
      return d;
    }
  }
  *n = Vec3::UnitZ();
  return std::numeric_limits<double>::infinity();
}

bool AnalyticObstacle::validate(const std::string& p, std::string* why) const {
  using namespace config_check;
  if (!finiteVec(p + "center_m", center_m, why)) return false;
  switch (shape) {
    case Shape::kSphere:
      return positive(p + "radius_m", radius_m, why);
    case Shape::kBox:
      if (!orientation.coeffs().allFinite() || std::abs(orientation.norm() - 1.0) > 1e-6) {
        if (why) *why = p + "orientation: not a unit quaternion";
        return false;
      }
      return positive(p + "half_extents_m.x", half_extents_m.x(), why) &&
             positive(p + "half_extents_m.y", half_extents_m.y(), why) &&
             positive(p + "half_extents_m.z", half_extents_m.z(), why);
    case Shape::kPlane:
      if (!normal.allFinite() || std::abs(normal.norm() - 1.0) > 1e-6) {
        if (why) *why = p + "normal: must be a unit vector";
        return false;
      }
      return true;
  }
  return false;
}

bool AnalyticObstacle::parse(const std::string& spec, AnalyticObstacle* out, std::string* why) {
  AnalyticObstacle o;
  const size_t colon = spec.find(':');
  const std::string kind = spec.substr(0, colon);
  if (kind == "sphere")
    o.shape = Shape::kSphere;
  else if (kind == "box")
    o.shape = Shape::kBox;
  else if (kind == "plane")
    o.shape = Shape::kPlane;
  else {
    if (why) *why = "obstacle: '" + kind + "' is not sphere, box or plane";
    return false;
  }
  std::map<std::string, double> v;
  if (colon != std::string::npos) {
    std::stringstream list(spec.substr(colon + 1));
    std::string item;
    while (std::getline(list, item, ',')) {
      const size_t eq = item.find('=');
      const std::string key = item.substr(0, eq);
      const std::string text = eq == std::string::npos ? "" : item.substr(eq + 1);
      char* end = nullptr;
      const double value = std::strtod(text.c_str(), &end);
      if (text.empty() || *end != '\0' || !std::isfinite(value)) {
        if (why) *why = "obstacle " + kind + "." + key + ": '" + text + "' is not a finite number";
        return false;
      }
      v[key] = value;
    }
  }
  std::vector<std::string> allowed = {"x", "y", "z"};
  if (o.shape == Shape::kSphere) allowed.push_back("r");
  if (o.shape == Shape::kBox) allowed.insert(allowed.end(), {"hx", "hy", "hz"});
  if (o.shape == Shape::kPlane) allowed.insert(allowed.end(), {"nx", "ny", "nz"});
  for (const auto& kv : v) {
    bool ok = false;
    for (const std::string& a : allowed) ok = ok || kv.first == a;
    if (!ok) {
      if (why) *why = "obstacle " + kind + "." + kv.first + ": unknown key";
      return false;
    }
  }
  auto get = [&](const char* k, double dflt) { return v.count(k) ? v[k] : dflt; };
  o.center_m = Vec3(get("x", 0.0), get("y", 0.0), get("z", 0.0));
  o.radius_m = get("r", 0.1);
  o.half_extents_m = Vec3(get("hx", 0.1), get("hy", 0.1), get("hz", 0.1));
  const Vec3 n(get("nx", 0.0), get("ny", 0.0), get("nz", 1.0));
  if (o.shape == Shape::kPlane && n.norm() < 1e-12) {
    if (why) *why = "obstacle plane.n: the normal must not be zero";
    return false;
  }
  o.normal = n.normalized();
  if (!o.validate("obstacle " + kind + ".", why)) return false;
  *out = o;
  return true;
}

double Obstacles::distance(const Vec3& x, Vec3* n) const {
  V3<double> nv;
  const double d = distance(toV3(x), Vec3::Zero(), true, &nv);
  *n = toEigen(nv);
  return d;
}

}  // namespace wet_curly_hair
