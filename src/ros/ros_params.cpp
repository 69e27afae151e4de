#include "wet_curly_hair/ros/ros_params.h"

#include <XmlRpcValue.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

namespace wet_curly_hair {

using io::parameterTable;
using io::ParamRef;

namespace {

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

const char* typeName(ParamRef::Type t) {
  switch (t) {
    case ParamRef::Type::kDouble:
      return "a number";
    case ParamRef::Type::kInt:
      return "an integer";
    case ParamRef::Type::kBool:
      return "a boolean (true/false)";
    case ParamRef::Type::kString:
      return "a string";
  }
  return "?";
}

const char* xmlTypeName(const XmlRpc::XmlRpcValue& v) {
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return "a boolean";
    case XmlRpc::XmlRpcValue::TypeInt:
      return "an integer";
    case XmlRpc::XmlRpcValue::TypeDouble:
      return "a number";
    case XmlRpc::XmlRpcValue::TypeString:
      return "a string";
    case XmlRpc::XmlRpcValue::TypeArray:
      return "a list";
    case XmlRpc::XmlRpcValue::TypeStruct:
      return "a namespace (dictionary)";
    default:
      return "an unsupported type";
  }
}

/// Sets the field behind `ref` from a parameter-server value of a compatible type.
bool setFromXml(const ParamRef& ref, XmlRpc::XmlRpcValue& v, std::string* why) {
  using X = XmlRpc::XmlRpcValue;
  const std::string ros_name = "~" + rosParamName(ref.name);
  auto wrong = [&]() {
    *why = ros_name + ": expected " + typeName(ref.type) + ", got " + xmlTypeName(v);
    return false;
  };
  switch (ref.type) {
    case ParamRef::Type::kDouble:
      if (v.getType() == X::TypeDouble) {
        *static_cast<double*>(ref.field) = static_cast<double>(v);
      } else if (v.getType() == X::TypeInt) {
        *static_cast<double*>(ref.field) = static_cast<int>(v);
      } else {
        return wrong();
      }
      return true;
    case ParamRef::Type::kInt:
      if (v.getType() == X::TypeInt) {
        *static_cast<int*>(ref.field) = static_cast<int>(v);
        return true;
      }
      return wrong();
    case ParamRef::Type::kBool:
      if (v.getType() == X::TypeBoolean) {
        *static_cast<bool*>(ref.field) = static_cast<bool>(v);
        return true;
      }
      return wrong();
    case ParamRef::Type::kString:
      if (v.getType() == X::TypeString) {
        *static_cast<std::string*>(ref.field) = static_cast<std::string>(v);
        return true;
      }
      return wrong();
  }
  return wrong();
}

/// Adds the ROS names of a validation message ("solver.x.y: reason") for the reader.
std::string explainInvalid(const std::string& why) {
  const size_t colon = why.find(':');
  if (colon == std::string::npos) return why;
  const std::string dotted = why.substr(0, colon);
  if (dotted.find(' ') != std::string::npos) return why;
  return "invalid scene parameter " + why + " (ROS parameter ~" + rosParamName(dotted) +
         ", scene YAML key " + dotted + ")";
}

template <typename T>
bool readParam(const ros::NodeHandle& pnh, const std::string& name, T* value, const char* expected,
               std::string* why) {
  if (!pnh.hasParam(name)) return true;
  if (pnh.getParam(name, *value)) return true;
  XmlRpc::XmlRpcValue v;
  pnh.getParam(name, v);
  *why = "~" + name + ": expected " + expected + ", got " + xmlTypeName(v);
  return false;
}

bool readVec3(const ros::NodeHandle& pnh, const std::string& name, Vec3* out, std::string* why) {
  if (!pnh.hasParam(name)) return true;
  XmlRpc::XmlRpcValue v;
  pnh.getParam(name, v);
  if (v.getType() != XmlRpc::XmlRpcValue::TypeArray || v.size() != 3) {
    *why = "~" + name + ": expected a list of 3 numbers [x, y, z], got " + xmlTypeName(v);
    return false;
  }
  Vec3 r;
  for (int k = 0; k < 3; ++k) {
    if (v[k].getType() == XmlRpc::XmlRpcValue::TypeDouble) {
      r[k] = static_cast<double>(v[k]);
    } else if (v[k].getType() == XmlRpc::XmlRpcValue::TypeInt) {
      r[k] = static_cast<int>(v[k]);
    } else {
      *why = "~" + name + ": element " + std::to_string(k) + " is not a number";
      return false;
    }
  }
  if (!r.allFinite()) {
    *why = "~" + name + ": values must be finite";
    return false;
  }
  *out = r;
  return true;
}

bool checkFrame(const std::string& name, const std::string& frame, std::string* why) {
  if (frame.empty()) {
    *why = "~" + name + ": must not be empty";
    return false;
  }
  if (frame[0] == '/') {
    *why = "~" + name + ": '" + frame + "' starts with '/'; tf2 frame ids have no leading slash";
    return false;
  }
  return true;
}

}  // namespace

std::string rosParamName(const std::string& dotted) {
  std::string s = dotted;
  for (char& c : s)
    if (c == '.') c = '/';
  return s;
}

bool sceneFromRos(const ros::NodeHandle& pnh, io::SceneConfig* scene, std::string* source,
                  std::string* why) {
  std::string path;
  if (!readParam(pnh, "scene", &path, "a string (a scene .yaml, a .hair file, or builtin)", why))
    return false;
  io::SceneConfig s;
  if (path.empty() || path == "builtin") {
    s = io::builtinScene();
    *source = "built-in scene";
  } else if (endsWith(path, ".hair")) {
    s = io::builtinScene();
    s.groom_file.file = path;
    *source = "built-in scene with the groom of " + path;
  } else {
    io::SceneConfig loaded;  // defaults, not the built-in scene, under a scene file (as the runner)
    std::string e;
    if (!io::loadSceneFile(path, &loaded, &e)) {
      *why = "~scene: " + e;
      return false;
    }
    s = loaded;
    *source = "scene file " + path;
  }

  std::vector<ParamRef> table = parameterTable(&s);
  std::set<std::string> known, namespaces;
  for (const ParamRef& r : table) {
    const std::string n = rosParamName(r.name);
    known.insert(n);
    namespaces.insert(n.substr(0, n.find('/')));
  }
  // A typo under a scene namespace (~solver/bend/stifness) must not be ignored silently.
  std::vector<std::string> all;
  const std::string prefix = pnh.getNamespace() + "/";
  if (pnh.getParamNames(all)) {
    for (const std::string& full : all) {
      if (full.compare(0, prefix.size(), prefix) != 0) continue;
      const std::string rel = full.substr(prefix.size());
      const std::string top = rel.substr(0, rel.find('/'));
      if (namespaces.count(top) && !known.count(rel)) {
        std::string dotted = rel;
        std::replace(dotted.begin(), dotted.end(), '/', '.');
        const std::string renamed = io::unknownParameterMessage(dotted);
        if (renamed != dotted + ": unknown parameter") {
          *why = "~" + rel + " (" + renamed + ")";
          return false;
        }
        *why = "~" + rel +
               ": not a scene parameter (see ~get_parameters or docs/runner.md for the "
               "names; lists such as head.capsules are set in the scene file)";
        return false;
      }
    }
  }
  int overrides = 0;
  for (const ParamRef& r : table) {
    const std::string n = rosParamName(r.name);
    if (!pnh.hasParam(n)) continue;
    XmlRpc::XmlRpcValue v;
    pnh.getParam(n, v);
    if (!setFromXml(r, v, why)) return false;
    ++overrides;
  }
  // ~follow_ratio: the short name of ~groom/follow_ratio (one strand in K simulated).
  if (pnh.hasParam("follow_ratio")) {
    XmlRpc::XmlRpcValue v;
    pnh.getParam("follow_ratio", v);
    for (const ParamRef& r : table) {
      if (r.name != "groom.follow_ratio") continue;
      if (!setFromXml(r, v, why)) return false;
      ++overrides;
    }
  }
  // Analytic obstacles: ~obstacles, a list of spec strings, replaces the scene's list.
  if (pnh.hasParam("obstacles")) {
    XmlRpc::XmlRpcValue v;
    pnh.getParam("obstacles", v);
    if (v.getType() != XmlRpc::XmlRpcValue::TypeArray) {
      *why = "~obstacles: expected a list of spec strings (\"sphere:x=..,y=..,z=..,r=..\"), got " +
             std::string(xmlTypeName(v));
      return false;
    }
    std::vector<AnalyticObstacle> obstacles;
    for (int k = 0; k < v.size(); ++k) {
      if (v[k].getType() != XmlRpc::XmlRpcValue::TypeString) {
        *why = "~obstacles[" + std::to_string(k) + "]: expected a spec string";
        return false;
      }
      AnalyticObstacle o;
      std::string e;
      if (!AnalyticObstacle::parse(static_cast<std::string>(v[k]), &o, &e)) {
        *why = "~obstacles[" + std::to_string(k) + "]: " + e;
        return false;
      }
      obstacles.push_back(o);
    }
    s.obstacles = obstacles;
    ++overrides;
  }
  std::string e;
  if (!s.validate(&e)) {
    *why = explainInvalid(e);
    return false;
  }
  if (overrides > 0) *source += " + " + std::to_string(overrides) + " private ROS parameter(s)";
  *scene = s;
  return true;
}

namespace {

XmlRpc::XmlRpcValue toXml(const ParamRef& r) {
  switch (r.type) {
    case ParamRef::Type::kDouble:
      return XmlRpc::XmlRpcValue(*static_cast<double*>(r.field));
    case ParamRef::Type::kInt:
      return XmlRpc::XmlRpcValue(*static_cast<int*>(r.field));
    case ParamRef::Type::kBool:
      return XmlRpc::XmlRpcValue(*static_cast<bool*>(r.field));
    case ParamRef::Type::kString:
      return XmlRpc::XmlRpcValue(*static_cast<std::string*>(r.field));
  }
  return XmlRpc::XmlRpcValue();
}

}  // namespace

void mirrorSceneToRos(const ros::NodeHandle& pnh, io::SceneConfig scene) {
  for (const ParamRef& r : parameterTable(&scene)) pnh.setParam(rosParamName(r.name), toXml(r));
  std::vector<std::string> specs;
  for (const AnalyticObstacle& o : scene.obstacles) specs.push_back(io::obstacleSpec(o));
  pnh.setParam("obstacles", specs);
}

void mirrorSceneToRos(const ros::NodeHandle& pnh, io::SceneConfig scene,
                      const std::vector<std::string>& names) {
  const std::set<std::string> wanted(names.begin(), names.end());
  for (const ParamRef& r : parameterTable(&scene))
    if (wanted.count(r.name)) pnh.setParam(rosParamName(r.name), toXml(r));
}

bool NodeConfig::validate(std::string* why) const {
  using namespace config_check;
  if (!checkFrame("world_frame", world_frame, why) || !checkFrame("head_frame", head_frame, why))
    return false;
  if (world_frame == head_frame) {
    *why =
        "~head_frame: equals ~world_frame ('" + world_frame + "'); the head must be its own frame";
    return false;
  }
  if (!obstacle_map_frame.empty() && !checkFrame("obstacle_map_frame", obstacle_map_frame, why))
    return false;
  return finiteInRange("~publish_rate", publish_rate, 0.1, 1000.0, why) &&
         finiteInRange("~tf_timeout_s", tf_timeout_s, 0.0, 10.0, why) &&
         finiteInRange("~max_catchup_frames", max_catchup_frames, 1, 100000, why) &&
         finiteInRange("~marker_line_width_m", marker_line_width_m, 1e-6, 1.0, why) &&
         finiteInRange("~marker_max_strands", marker_max_strands, 0, 100000000, why) &&
         finiteInRange("~map_frame_timeout_s", map_frame_timeout_s, 0.0, 60.0, why);
}

bool nodeConfigFromRos(const ros::NodeHandle& pnh, NodeConfig* config, std::string* why) {
  NodeConfig c;
  if (!readParam(pnh, "world_frame", &c.world_frame, "a string", why) ||
      !readParam(pnh, "head_frame", &c.head_frame, "a string", why) ||
      !readParam(pnh, "publish_rate", &c.publish_rate, "a number (Hz)", why) ||
      !readParam(pnh, "tf_timeout_s", &c.tf_timeout_s, "a number (s)", why) ||
      !readParam(pnh, "max_catchup_frames", &c.max_catchup_frames, "an integer", why) ||
      !readParam(pnh, "publish_markers", &c.publish_markers, "a boolean", why) ||
      !readParam(pnh, "marker_line_width_m", &c.marker_line_width_m, "a number (m)", why) ||
      !readParam(pnh, "marker_max_strands", &c.marker_max_strands, "an integer", why) ||
      !readParam(pnh, "obstacle_map_frame", &c.obstacle_map_frame, "a string (frame id)", why) ||
      !readParam(pnh, "map_frame_timeout_s", &c.map_frame_timeout_s, "a number (s)", why))
    return false;
  if (!c.validate(why)) return false;
  *config = c;
  return true;
}

bool HeadMotionPublisherConfig::validate(std::string* why) const {
  using namespace config_check;
  if (!checkFrame("world_frame", world_frame, why) || !checkFrame("head_frame", head_frame, why))
    return false;
  if (world_frame == head_frame) {
    *why = "~head_frame: equals ~world_frame";
    return false;
  }
  if (!finiteInRange("~rate", rate, 0.1, 10000.0, why)) return false;
  if (motions.empty()) {
    *why = "~motion: no motion given";
    return false;
  }
  if (!base.isFinite()) {
    *why = "~base_xyz/~base_rpy: not finite";
    return false;
  }
  return true;
}

bool parseMotionChain(const std::string& spec, std::vector<HeadMotionConfig>* motions,
                      std::string* why) {
  std::vector<HeadMotionConfig> out;
  std::stringstream ss(spec);
  std::string part;
  while (std::getline(ss, part, '+')) {
    HeadMotionConfig m;
    std::string e;
    if (!parseMotionSpec(part, &m, &e) || !m.validate("", &e)) {
      *why = "~motion: '" + part + "': " + e;
      return false;
    }
    out.push_back(m);
  }
  if (out.empty()) {
    *why = "~motion: empty";
    return false;
  }
  *motions = out;
  return true;
}

bool headMotionPublisherConfigFromRos(const ros::NodeHandle& pnh, HeadMotionPublisherConfig* config,
                                      std::string* why) {
  HeadMotionPublisherConfig c;
  Vec3 xyz = Vec3::Zero(), rpy = Vec3::Zero();
  if (!readParam(pnh, "world_frame", &c.world_frame, "a string", why) ||
      !readParam(pnh, "head_frame", &c.head_frame, "a string", why) ||
      !readParam(pnh, "rate", &c.rate, "a number (Hz)", why) ||
      !readParam(pnh, "motion", &c.motion, "a string such as nod:freq_hz=0.5", why) ||
      !readVec3(pnh, "base_xyz", &xyz, why) || !readVec3(pnh, "base_rpy", &rpy, why) ||
      !parseMotionChain(c.motion, &c.motions, why))
    return false;
  c.base.translation = xyz;
  c.base.rotation =
      Quat(Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
           Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()));
  if (!c.validate(why)) return false;
  *config = c;
  return true;
}

}  // namespace wet_curly_hair
