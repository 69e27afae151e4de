// Scene files (YAML, yaml-cpp): groom, head, solver settings and scripted head motion, and the
// table of dotted parameter names shared by the scene YAML, ROS parameters and the
// set_parameters service ("solver.stretch.axial_stiffness_n", "groom.strands", ...).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/head_collider.h"
#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/obstacles.h"
#include "wet_curly_hair/core/water.h"

namespace wet_curly_hair {
namespace io {

/// Where the groom comes from when `groom.file` is set (a .hair file) instead of the generator.
struct GroomFileConfig {
  std::string file;              ///< path of a .hair file; empty: generate from `groom`.
  double scale = 1.0;            ///< metres per file unit.
  std::string up_axis = "z";     ///< the file's up axis: x, y, z, -x, -y, -z.
  Vec3 offset_m = Vec3::Zero();  ///< added after scale and axis change (head frame).
  int resample_particles = 0;    ///< 0 keeps the file's points.
  /// 0: off; else resample every strand to edges of about this length, m (particles per strand
  /// follow its length, at least 3). Exclusive with resample_particles.
  double resample_edge_m = 0.0;
  /// Shortest edge an imported strand keeps, m (0: off): a strand sampled finer is resampled to
  /// fewer particles (unless resample_* is set), and a strand shorter than two such edges is
  /// skipped as too short to bend (HairImportOptions::min_edge_m).
  double min_edge_m = 0.001;
  /// Each strand moved rigidly so that its root lies on the head's ellipsoid (for a groom authored
  /// on another head; HairImportOptions::roots_on_scalp).
  bool roots_on_scalp = false;
};

/// Initial saturation: a root-to-tip ramp on every strand (scene section `saturation`).
struct SaturationInit {
  double root = 0.0;  ///< saturation at the roots, [0, 1].
  double tip = 0.0;   ///< saturation at the tips, [0, 1].
};

/// Run settings for the offline runner.
struct RunConfig {
  double seconds = 2.0;             ///< simulated time, s.
  double frame_s = 1.0 / 60.0;      ///< output frame (one solver step), s.
  double strand_radius_m = 0.0005;  ///< for the tangle count: segments closer than this touch.
  double clump_search_m = 0.05;     ///< clump distance: nearest other strand searched this far.
  bool validate(const std::string& prefix, std::string* why) const;
};

/// An OctoMap obstacle file placed in the world (scene section `obstacle_map`).
struct ObstacleMapConfig {
  std::string file;              ///< .bt or .ot; empty: none.
  Vec3 offset_m = Vec3::Zero();  ///< the map frame's origin in the world, m.
  double resolution_m = 0.005;   ///< voxel size of the signed distance field, m.
  double margin_m = 0.05;        ///< the reach box is grown by this, m.
  bool unknown_is_occupied = false;
};

/// A whole scene.
struct SceneConfig {
  GroomConfig groom;
  GroomFileConfig groom_file;
  HeadShape head;
  SolverConfig solver;
  HeadMotionConfig motion;
  RunConfig run;
  SaturationInit saturation;
  /// External obstacles in the world frame, as spec strings in the YAML list `obstacles`
  /// ("sphere:x=..,y=..,z=..,r=..", "box:...", "plane:..."; see AnalyticObstacle::parse).
  std::vector<AnalyticObstacle> obstacles;
  ObstacleMapConfig obstacle_map;
  /// Water that moves (scene section `water`, docs/water.md): the material keys, and the
  /// sources and dryers as spec strings in the lists `water.sources` ("shower:...", "bath:...")
  /// and `water.dryers` ("box:...").
  WaterConfig water;
  WaterSources water_sources;
  /// Whether the water stage runs: water.enabled, or any source or dryer.
  bool waterActive() const { return water.enabled || !water_sources.empty(); }
  bool validate(std::string* why) const;
};

/// One named, typed parameter of a SceneConfig.
struct ParamRef {
  enum class Type { kDouble, kInt, kBool, kString };
  std::string name;  ///< dotted name, e.g. "solver.bend.stiffness_n_m2".
  Type type;
  void* field;         ///< points into the SceneConfig the table was made for.
  std::string doc;     ///< unit and meaning.
  bool needs_rebuild;  ///< true when changing it requires rebuilding the model (reset).
  double getAsDouble() const;
  /// Sets from a double (bools: 0 or 1; ints: integral values only). False with a reason if the
  /// value cannot represent the type; range checks are SceneConfig::validate's job.
  bool setFromDouble(double v, std::string* why) const;
  std::string valueString() const;
};

/// The parameter table for `scene` (pointers into it: keep the scene alive and unmoved).
std::vector<ParamRef> parameterTable(SceneConfig* scene);

/// "<name>: unknown parameter", or for a key the per-length parameters replaced (a per-particle
/// mass, a per-edge spring constant, a smoothing length in edges) the key that replaced it with
/// its unit, so that an old scene or launch file fails with what to write instead.
std::string unknownParameterMessage(const std::string& dotted_name);

/// Applies name/value pairs all-or-nothing: on any unknown name, bad type or failed validation,
/// *scene is unchanged and *why names the parameter. *needs_rebuild tells whether a change
/// touched the groom, head or smoothing lengths (the model must be rebuilt), or, with
/// solver.sag_free on, an input of the sag-free solve (gravity, EA, B, strain limit).
bool applyParameters(const std::vector<std::string>& names, const std::vector<double>& values,
                     SceneConfig* scene, bool* needs_rebuild, std::string* why);

/// Parses scene YAML text into *scene, starting from its current values. Unknown keys, values of
/// the wrong type, NaN and out-of-range values are refused with the dotted key named; on failure
/// *scene is unchanged.
bool parseSceneYaml(const std::string& text, SceneConfig* scene, std::string* why);
bool loadSceneFile(const std::string& path, SceneConfig* scene, std::string* why);

/// The scene as YAML text (every parameter, with its documentation as comments).
std::string sceneToYaml(const SceneConfig& scene);

/// "a.b.c", "v" -> "{a: {b: {c: v}}}": one dotted override as scene YAML (the value is YAML
/// text, so numbers, booleans and strings all work).
std::string dottedToYaml(const std::string& dotted_name, const std::string& value_text);

/// The spec string of an analytic obstacle (what AnalyticObstacle::parse reads back).
std::string obstacleSpec(const AnalyticObstacle& obstacle);

/// The built-in scene: soft curly hair, wet toward the tips, on the default head, nodding
/// (`config/scenes/default.yaml` is a copy of it, kept in step by a test).
SceneConfig builtinScene();

}  // namespace io
}  // namespace wet_curly_hair
