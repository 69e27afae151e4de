#include "wet_curly_hair/ros/node.h"

#include <signal.h>

#include <algorithm>
#include <boost/make_shared.hpp>
#include <chrono>
#include <cmath>
#include <future>
#include <set>
#include <sstream>
#include <stdexcept>

#include "wet_curly_hair/io/scene_setup.h"
#include "wet_curly_hair/io/stage_clock.h"
#include "wet_curly_hair/ros/conversions.h"

namespace wet_curly_hair {

using io::parameterTable;
using io::ParamRef;

namespace {

/// What the groom's import said, logged: strands skipped and roots inside the head as warnings,
/// the roots moved onto the scalp as information.
void logImportReport(const io::HairImportReport& report) {
  if (!report.skipped.empty()) ROS_WARN("groom_file.file: %s", report.warning().c_str());
  if (!report.rootsInsideWarning().empty())
    ROS_WARN("groom_file.file: %s", report.rootsInsideWarning().c_str());
  if (!report.scalpSummary().empty()) ROS_INFO("groom_file.%s", report.scalpSummary().c_str());
}

double wallSince(const std::chrono::steady_clock::time_point& t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

using Clock = std::chrono::steady_clock;

int64_t floorDiv(int64_t a, int64_t b) { return a / b - ((a % b != 0) && ((a < 0) != (b < 0))); }

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

volatile sig_atomic_t g_signal = 0;
void onSignal(int sig) { g_signal = sig; }

}  // namespace

void spinUntilSignal() {
  signal(SIGINT, onSignal);
  signal(SIGTERM, onSignal);
  ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
  while (ros::ok() && g_signal == 0) queue->callAvailable(ros::WallDuration(0.05));
}

// ------------------------------------------------------------------------------------------
// construction

WetCurlyHairNode::WetCurlyHairNode(const ros::NodeHandle& nh, const ros::NodeHandle& pnh)
    : nh_(nh), pnh_(pnh) {
  std::string why;
  if (!nodeConfigFromRos(pnh_, &config_, &why)) throw std::runtime_error(why);
  if (!sceneFromRos(pnh_, &scene_, &scene_source_, &why)) throw std::runtime_error(why);
  // Remember what the user set, so that the mirror can be removed at exit without touching it.
  io::SceneConfig probe;
  for (const ParamRef& r : parameterTable(&probe)) {
    const std::string n = rosParamName(r.name);
    XmlRpc::XmlRpcValue v;
    if (pnh_.getParam(n, v)) user_scene_values_[n] = v;
  }
  XmlRpc::XmlRpcValue obstacles;
  if (pnh_.getParam("obstacles", obstacles)) user_scene_values_["obstacles"] = obstacles;
  init();
}

WetCurlyHairNode::WetCurlyHairNode(const ros::NodeHandle& nh, const ros::NodeHandle& pnh,
                                   const NodeConfig& config, const io::SceneConfig& scene,
                                   const std::string& scene_source)
    : nh_(nh), pnh_(pnh), config_(config), scene_source_(scene_source), scene_(scene) {
  std::string why;
  if (!config_.validate(&why)) throw std::runtime_error(why);
  if (!scene_.validate(&why)) throw std::runtime_error("invalid scene: " + why);
  init();
}

void WetCurlyHairNode::init() {
  std::string why;
  io::HairImportReport report;
  if (!io::buildSceneModel(scene_, &model_, &why, &report))
    throw std::runtime_error("cannot build the hair model of the " + scene_source_ + ": " + why);
  strands_skipped_ = static_cast<uint32_t>(report.skipped.size());
  logImportReport(report);
  frame_ns_ = std::llround(1e9 / config_.publish_rate);
  frame_s_ = frame_ns_ * 1e-9;
  obstacles_.analytic = scene_.obstacles;
  water_sources_ = scene_.water_sources;
  water_active_ = scene_.waterActive();
  resetHairLocked(Pose(), "start-up");
  reset_count_ = 0;
  io::stageClockSeconds();  // its rate measured here, not in the first step

  builder_ = std::make_unique<ObstacleFieldBuilder>(
      [this](const ObstacleFieldBuilder::Result& r) { onFieldBuilt(r); });
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_, nh_);

  nh_input_ = nh_;
  pnh_input_ = pnh_;
  nh_input_.setCallbackQueue(&input_queue_);
  pnh_input_.setCallbackQueue(&input_queue_);

  strands_pub_ = pnh_.advertise<Strands>("strands", 10);
  status_pub_ = pnh_.advertise<Status>("status", 10);
  if (config_.publish_markers)
    markers_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("markers", 2);

  // The scene's obstacle map (refused: the node does not start; better than running without
  // the obstacle the user asked for).
  if (!scene_.obstacle_map.file.empty()) {
    std::string message;
    if (!buildSceneMap(scene_, &message))
      throw std::runtime_error(message +
                               " (the obstacle_map.* scene parameters, ROS ~obstacle_map/)");
    ROS_INFO("%s", message.c_str());
    std::lock_guard<std::mutex> lock(sim_mutex_);
    swapInFieldLocked();
  }

  set_saturation_srv_ =
      pnh_input_.advertiseService("set_saturation", &WetCurlyHairNode::onSetSaturation, this);
  set_parameters_srv_ =
      pnh_input_.advertiseService("set_parameters", &WetCurlyHairNode::onSetParameters, this);
  get_parameters_srv_ =
      pnh_input_.advertiseService("get_parameters", &WetCurlyHairNode::onGetParameters, this);
  reset_srv_ = pnh_input_.advertiseService("reset", &WetCurlyHairNode::onReset, this);
  load_map_srv_ =
      pnh_input_.advertiseService("load_obstacle_map", &WetCurlyHairNode::onLoadObstacleMap, this);
  octomap_sub_ = nh_input_.subscribe("octomap_binary", 1, &WetCurlyHairNode::onOctomap, this);
  saturation_sub_ =
      pnh_input_.subscribe("saturation_changes", 100, &WetCurlyHairNode::onSaturationChange, this);
  set_water_srv_ = pnh_input_.advertiseService("set_water", &WetCurlyHairNode::onSetWater, this);
  water_sub_ = pnh_input_.subscribe("water_changes", 100, &WetCurlyHairNode::onWaterChange, this);

  mirrorSceneToRos(pnh_, scene_);

  input_spinner_ = std::make_unique<ros::AsyncSpinner>(2, &input_queue_);
  input_spinner_->start();
  timer_ = nh_.createTimer(ros::Duration(frame_s_), &WetCurlyHairNode::onTimer, this);

  ROS_INFO(
      "wet_curly_hair: %s; %d strands, %d particles; frame %.6f s (%.3g Hz) in %d substeps; "
      "head pose %s -> %s over tf2 (wait <= %.3f s); %zu analytic obstacle(s); cohesion %s",
      scene_source_.c_str(), model_.strandCount(), model_.particleCount(), frame_s_,
      config_.publish_rate, substepCount(scene_.solver, frame_s_), config_.world_frame.c_str(),
      config_.head_frame.c_str(), config_.tf_timeout_s, obstacles_.analytic.size(),
      scene_.solver.cohesion.mode.c_str());
}

WetCurlyHairNode::~WetCurlyHairNode() {
  timer_.stop();
  if (input_spinner_) input_spinner_->stop();
  builder_.reset();  // joins the worker before the members its callback touches go away
  // Remove the parameter mirror (restoring what the user set), so that a restart starts again
  // from the scene and the launch parameters rather than from this run's live values. After
  // ros::shutdown() roscpp still makes each master call once but does not wait for a master
  // that is gone (as when roscore and the node are stopped together).
  {
    io::SceneConfig probe;
    for (const ParamRef& r : parameterTable(&probe)) {
      const std::string n = rosParamName(r.name);
      auto it = user_scene_values_.find(n);
      if (it != user_scene_values_.end())
        pnh_.setParam(n, it->second);
      else
        pnh_.deleteParam(n);
    }
    auto it = user_scene_values_.find("obstacles");
    if (it != user_scene_values_.end())
      pnh_.setParam("obstacles", it->second);
    else
      pnh_.deleteParam("obstacles");
  }
}

// ------------------------------------------------------------------------------------------
// the clock

void WetCurlyHairNode::onTimer(const ros::TimerEvent&) {
  const ros::Time now = ros::Time::now();
  if (now.isZero()) return;  // /use_sim_time and no /clock yet
  const int64_t now_ns = static_cast<int64_t>(now.toNSec());
  {
    std::lock_guard<std::mutex> lock(sim_mutex_);
    if (!started_ || now < last_now_) {
      // Frames lie on a fixed grid of ROS time (multiples of the frame), so that a replayed bag
      // meets the same frame boundaries every time.
      if (started_) {
        ++time_jumps_back_;
        pending_changes_.clear();  // scheduled on the old timeline
        pending_water_.clear();
        pose_ever_ = false;  // take the pose again, as at start-up
        resetHairLocked(head_pose_, "ROS time jumped back");
        ROS_WARN("ROS time jumped back by %.3f s (a looping bag?): the hair is reset",
                 (last_now_ - now).toSec());
      }
      started_ = true;
      sim_ns_ = floorDiv(now_ns, frame_ns_) * frame_ns_;
      rtf_wall_start_ = ros::WallTime::now();
      rtf_frames_start_ = frames_stepped_;
    }
    last_now_ = now;
    tick_step_s_ = tick_convert_s_ = tick_publish_s_ = tick_tf_s_ = 0.0;
    tick_frames_ = 0;
  }
  // Only this thread writes sim_ns_, so reading it unlocked here is safe.
  int64_t frames = (now_ns - sim_ns_) / frame_ns_;
  if (frames <= 0) return;
  if (frames > config_.max_catchup_frames) {
    std::lock_guard<std::mutex> lock(sim_mutex_);
    const int64_t skip = frames - config_.max_catchup_frames;
    skipped_frames_ += static_cast<uint64_t>(skip);
    sim_ns_ += skip * frame_ns_;
    frames = config_.max_catchup_frames;
    // Throttled on the wall clock (ROS_WARN_THROTTLE goes silent after sim time jumps back).
    if ((ros::WallTime::now() - skip_warned_at_).toSec() > 5.0) {
      skip_warned_at_ = ros::WallTime::now();
      ROS_WARN(
          "cannot keep up with ROS time at t = %.3f s: skipped %lld frame(s) (%llu in total); "
          "the hair holds still over the gap. Lower ~publish_rate or the strand count, or "
          "raise ~max_catchup_frames (%d).",
          now.toSec(), static_cast<long long>(skip),
          static_cast<unsigned long long>(skipped_frames_), config_.max_catchup_frames);
    }
  }
  for (int64_t f = 0; f < frames; ++f) {
    const int64_t t_end = sim_ns_ + frame_ns_;
    const auto t0 = Clock::now();
    const PoseLookup lookup = lookupHeadPose(t_end, now);
    const double tf_s = wallSince(t0);
    std::lock_guard<std::mutex> lock(sim_mutex_);
    tick_tf_s_ += tf_s;
    advanceFrameLocked(t_end, lookup);
  }

  // Once per tick: markers of the last frame, and the status.
  std::lock_guard<std::mutex> lock(sim_mutex_);
  std_msgs::Header header;
  header.stamp.fromNSec(static_cast<uint64_t>(sim_ns_));
  header.frame_id = config_.world_frame;
  if (config_.publish_markers && markers_pub_.getNumSubscribers() > 0) {
    auto t0 = Clock::now();
    // Only "ours" computes display positions p^w; the other modes leave them equal to x.
    stateToMarkerArray(model_, state_, scene_.solver.cohesion.mode == "ours", header,
                       config_.marker_line_width_m, &markers_msg_,
                       markerStrandStride(model_.strandCount(), config_.marker_max_strands));
    appendSceneMarkersLocked(header);
    tick_convert_s_ += wallSince(t0);
    t0 = Clock::now();
    markers_pub_.publish(markers_msg_);
    ++markers_published_;
    tick_publish_s_ += wallSince(t0);
  }
  const ros::WallTime wall = ros::WallTime::now();
  const double window = (wall - rtf_wall_start_).toSec();
  if (window >= 1.0) {  // frames simulated (not skipped) per wall second
    real_time_factor_ = (frames_stepped_ - rtf_frames_start_) * frame_s_ / window;
    rtf_wall_start_ = wall;
    rtf_frames_start_ = frames_stepped_;
  }
  Status status;
  auto t0 = Clock::now();
  fillStatusLocked(&status);
  tick_convert_s_ += wallSince(t0);
  status_pub_.publish(status);
}

WetCurlyHairNode::PoseLookup WetCurlyHairNode::lookupHeadPose(int64_t t_ns, const ros::Time& now) {
  PoseLookup r;
  ros::Time t;
  t.fromNSec(static_cast<uint64_t>(t_ns));
  try {
    // Latest transform: tells whether the frames are connected at all and how fresh the data is.
    const geometry_msgs::TransformStamped latest =
        tf_buffer_.lookupTransform(config_.world_frame, config_.head_frame, ros::Time(0));
    if (!latest.header.stamp.isZero() && t > latest.header.stamp) {
      // The pose at t is not there yet: wait for it, but never past tf_timeout_s after the
      // newest data, so that a publisher that stopped costs no waiting at all.
      // The bound is on the wall clock: a paused or lock-stepped /clock does not move while
      // we wait.
      const double wait = std::clamp((latest.header.stamp - now).toSec() + config_.tf_timeout_s,
                                     0.0, config_.tf_timeout_s);
      const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(wait);
      while (!tf_buffer_.canTransform(config_.world_frame, config_.head_frame, t) &&
             ros::WallTime::now() < deadline && ros::ok())
        ros::WallDuration(0.0005).sleep();
    }
    const geometry_msgs::TransformStamped tr =
        tf_buffer_.lookupTransform(config_.world_frame, config_.head_frame, t);
    if (!poseFromTransform(tr.transform, &r.pose)) {
      r.error = "the transform " + config_.world_frame + " -> " + config_.head_frame +
                " is not finite or has a zero quaternion";
      return r;
    }
    r.ok = true;
    r.stamp_ns =
        static_cast<int64_t>(tr.header.stamp.isZero() ? t.toNSec() : tr.header.stamp.toNSec());
  } catch (const tf2::TransformException& e) {
    r.error = e.what();
  }
  return r;
}

void WetCurlyHairNode::advanceFrameLocked(int64_t t_end_ns, const PoseLookup& lookup) {
  swapInFieldLocked();
  ++tf_lookups_;
  head_pose_ok_ = lookup.ok;
  if (lookup.ok) {
    tf_error_.clear();
    last_pose_stamp_ns_ = lookup.stamp_ns;
  } else {
    ++tf_fallbacks_;
    tf_error_ = lookup.error;
    if ((ros::WallTime::now() - tf_warned_at_).toSec() > 5.0) {
      tf_warned_at_ = ros::WallTime::now();
      ROS_WARN("no head pose %s -> %s at t = %.3f s (%s); %s (%llu fallback(s) so far)",
               config_.world_frame.c_str(), config_.head_frame.c_str(), t_end_ns * 1e-9,
               lookup.error.c_str(),
               pose_ever_ ? "keeping the last pose" : "the head stays where it was",
               static_cast<unsigned long long>(tf_fallbacks_));
    }
  }
  if (lookup.ok && !pose_ever_) {
    // First pose (at start, or after time jumped back): start the hair at rest on it, keeping
    // the saturation set so far (a set_saturation answered with success before tf2 had the head
    // must not be undone by the pose arriving; after a time jump the reset has already put the
    // scene's ramp back). A one-off copy, outside the step.
    pose_ever_ = true;
    sim_ns_ = t_end_ns;
    const std::vector<double> saturation = state_.saturation;
    resetHairLocked(lookup.pose, "head pose received");
    state_.saturation = saturation;
    ROS_INFO("head pose %s -> %s received at t = %.3f s: hair placed on the head",
             config_.world_frame.c_str(), config_.head_frame.c_str(), t_end_ns * 1e-9);
    publishStrandsLocked();
    return;
  }
  const Pose end = lookup.ok ? lookup.pose : head_pose_;
  applyDueChangesLocked(sim_ns_);
  stepWaterLocked();
  StepInputs in;
  in.head_start = head_pose_;
  in.head_end = end;
  in.obstacles = obstacles_.empty() ? nullptr : &obstacles_;
  in.clock = &io::stageClockSeconds;  // stage timing for ~status (the core reads no clock)
  const auto t0 = Clock::now();
  step(model_, scene_.solver, in, frame_s_, &state_, &last_stats_);
  tick_step_s_ += wallSince(t0);
  ++tick_frames_;
  ++frames_stepped_;
  head_pose_ = end;
  sim_ns_ = t_end_ns;
  ++step_;
  countCrossingsLocked();
  publishStrandsLocked();
  maybeRebuildFieldLocked();
}

void WetCurlyHairNode::countCrossingsLocked() {
  if (!scene_.solver.hair_contact.enabled) {
    previous_position_.clear();
    return;
  }
  if (previous_position_.size() == state_.position.size())
    crossings_ += crossingCount(model_, previous_position_, state_.position, &crossing_scratch_,
                                scene_.solver.integrator.resolvedThreads());
  previous_position_ = state_.position;
}

void WetCurlyHairNode::resetHairLocked(const Pose& head_pose, const std::string& reason) {
  head_pose_ = head_pose;
  state_ = makeState(model_, head_pose, Twist());
  if (scene_.saturation.root != 0.0 || scene_.saturation.tip != 0.0) {
    SaturationCommand init;
    init.root_value = scene_.saturation.root;
    init.tip_value = scene_.saturation.tip;
    applySaturation(model_, init, head_pose_, &state_);
  }
  reach_radius_m_ = 0.0;
  for (int s = 0; s < model_.strandCount(); ++s)
    reach_radius_m_ =
        std::max(reach_radius_m_, model_.rest_position_head[model_.strandBegin(s)].norm() +
                                      model_.strand_length_m[s]);
  last_stats_ = StepStats();
  previous_position_.clear();
  crossings_ = 0;
  step_ = 0;
  ++reset_count_;
  last_reset_reason_ = reason;
}

void WetCurlyHairNode::applyDueChangesLocked(int64_t t_ns) {
  while (!pending_changes_.empty() && pending_changes_.begin()->first <= t_ns) {
    const SaturationCommand cmd = pending_changes_.begin()->second;
    pending_changes_.erase(pending_changes_.begin());
    std::string why;
    if (!validateSaturationCommand(cmd, model_, &why)) {  // the model may have changed since
      ROS_WARN("~saturation_changes: dropped at t = %.3f s: %s", t_ns * 1e-9, why.c_str());
      continue;
    }
    applySaturation(model_, cmd, head_pose_, &state_);
  }
}

void WetCurlyHairNode::stepWaterLocked() {
  while (!pending_water_.empty() && pending_water_.begin()->first <= sim_ns_) {
    const WaterCommand& c = pending_water_.begin()->second;
    if (c.clear) water_sources_ = WaterSources();
    for (const WaterSource& w : c.add.sources) water_sources_.sources.push_back(w);
    for (const WaterDryer& d : c.add.dryers) water_sources_.dryers.push_back(d);
    water_active_ = true;
    pending_water_.erase(pending_water_.begin());
  }
  water_step_s_ = 0.0;
  if (!water_active_) return;
  const auto t0 = Clock::now();
  reconcileWater(model_, scene_.water, &state_);  // books what commands set since the last frame
  stepWater(model_, scene_.water, water_sources_, scene_.solver.gravity_m_s2, sim_ns_ * 1e-9,
            frame_s_, &state_, nullptr);
  if (scene_.water.adds_mass) applyWaterMass(state_, &model_);
  water_step_s_ = wallSince(t0);
}

void WetCurlyHairNode::publishStrandsLocked() {
  // A frame nobody takes is not built (9 MB at 10,000 strands): as the markers.
  if (strands_pub_.getNumSubscribers() == 0) return;
  std_msgs::Header header;
  header.stamp.fromNSec(static_cast<uint64_t>(sim_ns_));
  header.frame_id = config_.world_frame;
  auto t0 = Clock::now();
  const boost::shared_ptr<Strands> frame = freeStrandsFrame();
  stateToStrandsMsg(model_, state_, scene_.solver.cohesion.mode != "off", header, step_,
                    reset_count_, head_pose_, frame.get(),
                    scene_.solver.integrator.resolvedThreads());
  tick_convert_s_ += wallSince(t0);
  t0 = Clock::now();
  strands_pub_.publish(boost::shared_ptr<const Strands>(frame));
  tick_publish_s_ += wallSince(t0);
}

boost::shared_ptr<Strands> WetCurlyHairNode::freeStrandsFrame() {
  // Held by nobody else (roscpp releases a frame once every subscriber queue and socket is done
  // with it): filled in place, its arrays already the right size. A subscriber may keep frames
  // (its queue, or a pointer of its own): up to kFrames are kept here, and when every one is
  // held a new frame replaces one in turn, the old one freed by its last holder.
  constexpr size_t kFrames = 4;
  for (const boost::shared_ptr<Strands>& f : strands_frames_)
    if (f.use_count() == 1) return f;
  auto fresh = boost::make_shared<Strands>();
  if (strands_frames_.size() < kFrames) {
    strands_frames_.push_back(fresh);
  } else {
    strands_frames_[next_strands_frame_] = fresh;
    next_strands_frame_ = (next_strands_frame_ + 1) % kFrames;
  }
  return fresh;
}

void WetCurlyHairNode::appendSceneMarkersLocked(const std_msgs::Header& header) {
  // The head in the world frame at head_pose_, the pose the solver used for this state, rather
  // than in the head frame: what is drawn is where the hair collided, in the same message and
  // stamp as the hair, also when the node fell back on the last pose (tf2 late or missing),
  // and RViz needs no transform at that stamp.
  appendHeadMarkers(model_.head, head_pose_, header, &markers_msg_);
  appendObstacleMarkers(obstacles_.analytic, head_pose_.translation, 4.0 * reach_radius_m_, header,
                        &markers_msg_);
  if (obstacles_.field.sdf) {
    // The surface is found once per field (a scan of the grid), then sent with every array so
    // that a display that subscribes late still gets it. At most 10,000 cubes (240 kB): about
    // the size of the built-in scene's hair marker.
    constexpr size_t kMaxFieldCubes = 10000;
    if (field_marker_of_.lock() != obstacles_.field.sdf) {
      obstacleFieldMarker(obstacles_.field, kMaxFieldCubes, header, &field_marker_);
      field_marker_of_ = obstacles_.field.sdf;
    }
    field_marker_.header = header;
    markers_msg_.markers.push_back(field_marker_);
  }
  deleteVanishedMarkers(&published_markers_, &markers_msg_);
}

void WetCurlyHairNode::fillStatusLocked(Status* s) {
  s->header.stamp.fromNSec(static_cast<uint64_t>(sim_ns_));
  s->header.frame_id = config_.world_frame;
  s->step = step_;
  s->reset_count = reset_count_;
  s->frame_s = frame_s_;
  s->substeps = substepCount(scene_.solver, frame_s_);
  s->substep_s = frame_s_ / std::max(1, s->substeps);
  s->skipped_frames = skipped_frames_;
  s->markers_published = markers_published_;
  s->time_jumps_back = time_jumps_back_;
  const double frames = std::max(1, tick_frames_);
  s->step_time_s = tick_step_s_ / frames;
  s->conversion_time_s = tick_convert_s_ / frames;
  s->publish_time_s = tick_publish_s_ / frames;
  s->tf_lookup_time_s = tick_tf_s_ / frames;
  s->solver_real_time_factor = s->step_time_s > 0.0 ? frame_s_ / s->step_time_s : 0.0;
  s->real_time_factor = real_time_factor_;
  s->head_pose_ok = head_pose_ok_;
  s->head_pose_ever = pose_ever_;
  s->head_pose_age_s = last_pose_stamp_ns_ < 0 ? -1.0 : (sim_ns_ - last_pose_stamp_ns_) * 1e-9;
  s->tf_lookups = tf_lookups_;
  s->tf_fallbacks = tf_fallbacks_;
  s->tf_error = tf_error_;
  s->nonfinite_repairs = state_.warnings.nonfinite_repairs;
  s->strain_repairs = state_.warnings.strain_repairs;
  s->repaired_strands = state_.warnings.total();
  s->strain_limited_edges = last_stats_.strain_limited_edges;
  s->velocity_clamps = last_stats_.velocity_clamps;
  s->head_contacts = last_stats_.head_contacts;
  s->max_strain_before_limit = last_stats_.max_strain_before_limit;
  s->wet_strands = last_stats_.wet_strands;
  s->strands_near_obstacles = last_stats_.strands_near_obstacles;
  s->obstacle_contacts = last_stats_.obstacle_contacts;
  s->adhesion_active = last_stats_.adhesion_active;
  s->cohesion_particles = last_stats_.cohesion_particles;
  s->hair_contacts = last_stats_.hair_contacts;
  s->hair_contact_strands = last_stats_.hair_contact_strands;
  s->hair_contact_overflows = state_.warnings.hair_contact_overflows;
  s->crossings = scene_.solver.hair_contact.enabled ? crossings_ : -1;
  s->stage_names.clear();
  s->stage_times_s.clear();
  s->stage_particles.clear();
  for (int k = 0; k < kStageCount; ++k) {
    s->stage_names.push_back(stageName(k));
    s->stage_times_s.push_back(last_stats_.stage_cpu_s[k]);
    s->stage_particles.push_back(last_stats_.stage_particles[k]);
  }
  s->analytic_obstacles = static_cast<uint32_t>(obstacles_.analytic.size());
  s->obstacle_field_loaded = field_.loaded;
  s->obstacle_field_source = field_.source;
  s->obstacle_map_age_s = field_.loaded ? std::max(0.0, sim_ns_ * 1e-9 - field_.map_stamp_s) : -1.0;
  s->obstacle_field_age_s =
      field_.loaded ? (ros::WallTime::now() - field_.swapped_at).toSec() : -1.0;
  s->obstacle_field_cells = field_.cells;
  s->obstacle_field_building = builder_->busy();
  {
    std::lock_guard<std::mutex> lock(field_mutex_);
    s->obstacle_field_build_time_s = last_build_s_;
    s->obstacle_maps_refused = maps_refused_;
    s->obstacle_last_error = map_error_;
  }
  s->strands = model_.strandCount();
  s->particles = model_.particleCount();
  s->strands_skipped = strands_skipped_;
  s->saturation_changes_pending = static_cast<uint32_t>(pending_changes_.size());
  s->water_active = water_active_;
  const WaterLedger& l = state_.water_ledger;
  s->water_added_kg = l.added_kg;
  s->water_removed_kg = l.removed_kg;
  s->water_held_kg = heldWater(state_);
  s->water_dripped_kg = l.dripped_kg;
  s->water_evaporated_kg = l.evaporated_kg;
  s->water_drips = l.drips;
  s->mean_saturation = meanSaturation(state_);
  s->water_sources = static_cast<uint32_t>(water_sources_.sources.size());
  s->water_dryers = static_cast<uint32_t>(water_sources_.dryers.size());
  s->water_changes_pending = static_cast<uint32_t>(pending_water_.size());
  s->water_step_time_s = water_step_s_;
}

// ------------------------------------------------------------------------------------------
// obstacles

Eigen::AlignedBox3d WetCurlyHairNode::reachBoxLocked() const {
  const Vec3 r = Vec3::Constant(reach_radius_m_);
  return Eigen::AlignedBox3d(head_pose_.translation - r, head_pose_.translation + r);
}

io::SdfBuildConfig WetCurlyHairNode::sdfConfigOf(const io::SceneConfig& scene) {
  io::SdfBuildConfig c;
  c.resolution_m = scene.obstacle_map.resolution_m;
  c.margin_m = scene.obstacle_map.margin_m;
  c.unknown_is_occupied = scene.obstacle_map.unknown_is_occupied;
  return c;
}

bool WetCurlyHairNode::buildSceneMap(const io::SceneConfig& scene, std::string* message) {
  const io::ObstacleMapConfig& map = scene.obstacle_map;
  std::unique_ptr<octomap::OcTree> tree;
  std::string why;
  if (!io::loadOctreeFile(map.file, &tree, &why)) {
    *message = "obstacle_map.file: " + why;
    refuseMap(*message);
    return false;
  }
  const std::string frame =
      config_.obstacle_map_frame.empty() ? config_.world_frame : config_.obstacle_map_frame;
  auto built = std::make_shared<std::promise<ObstacleFieldBuilder::Result>>();
  auto future = built->get_future();
  if (!submitTree(
          std::shared_ptr<const octomap::OcTree>(std::move(tree)), frame, map.offset_m,
          sdfConfigOf(scene), map.file, ros::Time::now().toSec(),
          [built](const ObstacleFieldBuilder::Result& r) { built->set_value(r); }, &why)) {
    *message = "obstacle_map.file: " + why;
    refuseMap(*message);
    return false;
  }
  const ObstacleFieldBuilder::Result r = future.get();
  *message = r.message;
  return r.ok;
}

void WetCurlyHairNode::swapInFieldLocked() {
  std::lock_guard<std::mutex> lock(field_mutex_);
  if (field_remove_) {
    obstacles_.field = ObstacleField();
    field_ = FieldInfo();
    field_remove_ = false;
  }
  if (!field_ready_) return;
  field_ready_ = false;
  obstacles_.field = ready_.field;
  field_.loaded = true;
  field_.source = ready_.request.source;
  field_.map_stamp_s = ready_.request.map_stamp_s;
  field_.swapped_at = ros::WallTime::now();
  field_.cells = ready_.stats.cells;
  field_.request = ready_.request;
  ready_ = ObstacleFieldBuilder::Result();
}

void WetCurlyHairNode::maybeRebuildFieldLocked() {
  if (!field_.loaded || !field_.request.tree || builder_->busy()) return;
  // The field covers the box it was built for plus the build margin; rebuild around the head
  // when half of that margin is used up, so the new field is ready before the hair gets there.
  const Eigen::AlignedBox3d& built = field_.request.reach_box_world;
  const Eigen::AlignedBox3d need = reachBoxLocked();
  const double used =
      std::max((built.min() - need.min()).maxCoeff(), (need.max() - built.max()).maxCoeff());
  if (used <= 0.5 * field_.request.config.margin_m) return;
  ObstacleFieldBuilder::Request r = field_.request;
  r.reach_box_world = need;
  ROS_INFO("the head moved %.3f m out of the obstacle field's box: rebuilding it around the head",
           used);
  builder_->submit(r, nullptr);
}

bool WetCurlyHairNode::submitTree(std::shared_ptr<const octomap::OcTree> tree,
                                  const std::string& frame_id, const Vec3& offset_m,
                                  const io::SdfBuildConfig& sdf, const std::string& source,
                                  double stamp_s, ObstacleFieldBuilder::Callback done,
                                  std::string* why) {
  ObstacleFieldBuilder::Request r;
  r.tree = std::move(tree);
  r.config = sdf;
  r.source = source;
  r.map_stamp_s = stamp_s;
  if (frame_id != config_.world_frame) {
    std::string err;
    if (!tf_buffer_.canTransform(config_.world_frame, frame_id, ros::Time(0),
                                 ros::Duration(config_.map_frame_timeout_s), &err)) {
      *why = "the map frame '" + frame_id + "' does not resolve in '" + config_.world_frame +
             "' over tf2 within ~map_frame_timeout_s = " + fmt(config_.map_frame_timeout_s) + " s" +
             (err.empty() ? std::string() : ": " + err);
      return false;
    }
    try {
      const auto tr = tf_buffer_.lookupTransform(config_.world_frame, frame_id, ros::Time(0));
      if (!poseFromTransform(tr.transform, &r.tree_in_world)) {
        *why = "the transform " + config_.world_frame + " -> " + frame_id + " is not finite";
        return false;
      }
    } catch (const tf2::TransformException& e) {
      *why = std::string("tf2: ") + e.what();
      return false;
    }
  }
  Pose offset;
  offset.translation = offset_m;
  r.tree_in_world = r.tree_in_world * offset;
  {
    std::lock_guard<std::mutex> lock(sim_mutex_);
    r.reach_box_world = reachBoxLocked();
  }
  builder_->submit(r, std::move(done));
  return true;
}

void WetCurlyHairNode::refuseMap(const std::string& why) {
  std::lock_guard<std::mutex> lock(field_mutex_);
  ++maps_refused_;
  map_error_ = why;
  ROS_WARN("obstacle map refused (%u so far), the previous field stays: %s", maps_refused_,
           why.c_str());
}

void WetCurlyHairNode::onFieldBuilt(const ObstacleFieldBuilder::Result& r) {
  if (r.superseded) return;
  if (!r.ok) {
    refuseMap(r.message);
    return;
  }
  std::lock_guard<std::mutex> lock(field_mutex_);
  last_build_s_ = r.stats.total_s;
  ready_ = r;
  field_ready_ = true;
  field_remove_ = false;
  map_error_.clear();
  ROS_DEBUG("%s", r.message.c_str());
}

void WetCurlyHairNode::onOctomap(const OctomapCompat::ConstPtr& msg) {
  const std::string source = "topic " + octomap_sub_.getTopic();
  if (msg->header.frame_id.empty()) {
    refuseMap(source + ": header.frame_id is empty; set the map's frame");
    return;
  }
  std::unique_ptr<octomap::OcTree> tree;
  std::string why;
  if (!io::octreeFromMessagePayload(msg->binary, msg->id, msg->resolution, msg->data, &tree,
                                    &why)) {
    refuseMap(source + ": " + why);
    return;
  }
  io::SdfBuildConfig sdf;
  {
    std::lock_guard<std::mutex> lock(sim_mutex_);
    sdf = sdfConfigOf(scene_);
  }
  if (!submitTree(std::shared_ptr<const octomap::OcTree>(std::move(tree)), msg->header.frame_id,
                  Vec3::Zero(), sdf, source, msg->header.stamp.toSec(), nullptr, &why))
    refuseMap(source + ": " + why);
}

bool WetCurlyHairNode::onLoadObstacleMap(LoadObstacleMap::Request& req,
                                         LoadObstacleMap::Response& res) {
  res.success = false;
  if (req.path.empty()) {
    std::lock_guard<std::mutex> lock(field_mutex_);
    field_remove_ = true;
    field_ready_ = false;
    res.success = true;
    res.message = "obstacle field removed (before the next frame)";
    return true;
  }
  std::unique_ptr<octomap::OcTree> tree;
  std::string why;
  if (!io::loadOctreeFile(req.path, &tree, &why)) {
    refuseMap(why);
    res.message = "refused, the previous field stays: " + why;
    return true;
  }
  const std::string frame = req.frame_id.empty() ? config_.world_frame : req.frame_id;
  io::SdfBuildConfig sdf;
  {
    std::lock_guard<std::mutex> lock(sim_mutex_);
    sdf = sdfConfigOf(scene_);
  }
  auto built = std::make_shared<std::promise<ObstacleFieldBuilder::Result>>();
  auto future = built->get_future();
  if (!submitTree(
          std::shared_ptr<const octomap::OcTree>(std::move(tree)), frame, Vec3::Zero(), sdf,
          req.path, ros::Time::now().toSec(),
          [built](const ObstacleFieldBuilder::Result& r) { built->set_value(r); }, &why)) {
    refuseMap(req.path + ": " + why);
    res.message = "refused, the previous field stays: " + why;
    return true;
  }
  const ObstacleFieldBuilder::Result r = future.get();
  res.success = r.ok;
  res.message = r.ok ? r.message : "refused, the previous field stays: " + r.message;
  return true;
}

// ------------------------------------------------------------------------------------------
// services and scheduled changes

bool WetCurlyHairNode::onSetSaturation(SetSaturation::Request& req, SetSaturation::Response& res) {
  res.success = false;
  res.particles_changed = 0;
  SaturationCommand cmd;
  std::string why;
  if (!saturationCommandFromMsg(req, &cmd, &why)) {
    res.message = "refused, nothing changed: " + why;
    return true;
  }
  std::lock_guard<std::mutex> lock(sim_mutex_);
  if (!validateSaturationCommand(cmd, model_, &why)) {
    res.message = "refused, nothing changed: " + why;
    return true;
  }
  const int changed = applySaturation(model_, cmd, head_pose_, &state_);
  if (changed == 0) {
    res.message =
        "refused: the selection holds no particle (check the region's centre, size and "
        "frame against the hair), nothing changed";
    return true;
  }
  res.success = true;
  res.particles_changed = static_cast<uint32_t>(changed);
  res.message = std::string(cmd.add ? "added" : "set") + " saturation on " +
                std::to_string(changed) + " particle(s) (root " + fmt(cmd.root_value) + ", tip " +
                fmt(cmd.tip_value) + ")";
  return true;
}

void WetCurlyHairNode::onSaturationChange(const SaturationChange::ConstPtr& msg) {
  SaturationCommand cmd;
  std::string why;
  if (!saturationCommandFromMsg(*msg, &cmd, &why)) {
    ROS_WARN("~saturation_changes: refused: %s", why.c_str());
    return;
  }
  std::lock_guard<std::mutex> lock(sim_mutex_);
  if (!validateSaturationCommand(cmd, model_, &why)) {
    ROS_WARN("~saturation_changes: refused: %s", why.c_str());
    return;
  }
  const int64_t at =
      msg->header.stamp.isZero() ? INT64_MIN : static_cast<int64_t>(msg->header.stamp.toNSec());
  pending_changes_.emplace(at, cmd);  // equal stamps keep their arrival order
}

namespace {

/// Spec strings into sources and dryers, all or nothing; names the list, index and field.
bool parseWaterSpecs(const std::vector<std::string>& sources,
                     const std::vector<std::string>& dryers, WaterSources* out, std::string* why) {
  WaterSources parsed;
  for (size_t k = 0; k < sources.size(); ++k) {
    std::string inner;
    if (!WaterSource::parse(sources[k], &parsed.sources.emplace_back(), &inner)) {
      *why = "sources[" + std::to_string(k) + "]: " + inner;
      return false;
    }
  }
  for (size_t k = 0; k < dryers.size(); ++k) {
    std::string inner;
    if (!WaterDryer::parse(dryers[k], &parsed.dryers.emplace_back(), &inner)) {
      *why = "dryers[" + std::to_string(k) + "]: " + inner;
      return false;
    }
  }
  *out = parsed;
  return true;
}

}  // namespace

bool WetCurlyHairNode::onSetWater(SetWater::Request& req, SetWater::Response& res) {
  res.success = false;
  WaterSources add;
  std::string why;
  std::lock_guard<std::mutex> lock(sim_mutex_);
  res.sources_active = static_cast<uint32_t>(water_sources_.sources.size());
  res.dryers_active = static_cast<uint32_t>(water_sources_.dryers.size());
  if (!parseWaterSpecs(req.sources, req.dryers, &add, &why)) {
    res.message = "refused, nothing changed: " + why;
    return true;
  }
  if (req.clear) water_sources_ = WaterSources();
  for (const WaterSource& w : add.sources) water_sources_.sources.push_back(w);
  for (const WaterDryer& d : add.dryers) water_sources_.dryers.push_back(d);
  water_active_ = true;
  res.success = true;
  res.sources_active = static_cast<uint32_t>(water_sources_.sources.size());
  res.dryers_active = static_cast<uint32_t>(water_sources_.dryers.size());
  res.message = std::string(req.clear ? "stopped every source and dryer; " : "") + "added " +
                std::to_string(add.sources.size()) + " source(s) and " +
                std::to_string(add.dryers.size()) +
                " dryer(s); in use: " + std::to_string(res.sources_active) + " source(s), " +
                std::to_string(res.dryers_active) + " dryer(s)";
  return true;
}

void WetCurlyHairNode::onWaterChange(const WaterChange::ConstPtr& msg) {
  WaterCommand c;
  std::string why;
  if (!parseWaterSpecs(msg->sources, msg->dryers, &c.add, &why)) {
    ROS_WARN("~water_changes: refused: %s", why.c_str());
    return;
  }
  c.clear = msg->clear;
  std::lock_guard<std::mutex> lock(sim_mutex_);
  const int64_t at =
      msg->header.stamp.isZero() ? INT64_MIN : static_cast<int64_t>(msg->header.stamp.toNSec());
  pending_water_.emplace(at, c);  // equal stamps keep their arrival order
}

bool WetCurlyHairNode::onSetParameters(SetParameters::Request& req, SetParameters::Response& res) {
  res.success = false;
  res.reset = false;
  if (req.names.empty() && req.string_names.empty()) {
    res.message = "refused: no parameter given (names/values or string_names/string_values)";
    return true;
  }
  if (req.string_names.size() != req.string_values.size()) {
    res.message = "refused, nothing changed: string_names and string_values differ in length (" +
                  std::to_string(req.string_names.size()) + " vs " +
                  std::to_string(req.string_values.size()) + ")";
    return true;
  }
  // 1. Validate on a copy of the scene (all or nothing). Requests are serialised, so scene_
  //    cannot change under us until step 3.
  std::lock_guard<std::mutex> serialise(params_mutex_);
  io::SceneConfig copy;
  {
    std::lock_guard<std::mutex> lock(sim_mutex_);
    copy = scene_;
  }
  bool rebuild = false;
  std::string why;
  {
    const std::vector<ParamRef> table = parameterTable(&copy);
    for (size_t k = 0; k < req.string_names.size(); ++k) {
      const ParamRef* ref = nullptr;
      for (const ParamRef& r : table)
        if (r.name == req.string_names[k]) ref = &r;
      if (!ref) {
        res.message =
            "refused, nothing changed: " + io::unknownParameterMessage(req.string_names[k]);
        return true;
      }
      if (ref->type != ParamRef::Type::kString) {
        res.message = "refused, nothing changed: " + req.string_names[k] +
                      ": is a numeric parameter; give it in names/values";
        return true;
      }
      *static_cast<std::string*>(ref->field) = req.string_values[k];
      rebuild = rebuild || ref->needs_rebuild;
    }
  }
  bool numeric_rebuild = false;
  if (!io::applyParameters(req.names, req.values, &copy, &numeric_rebuild, &why)) {
    res.message = "refused, nothing changed: " + why;
    return true;
  }
  rebuild = rebuild || numeric_rebuild;
  // 2. The expensive parts, with the simulation running: a new model, a new obstacle field.
  HairModel model;
  io::HairImportReport report;
  if (rebuild && !io::buildSceneModel(copy, &model, &why, &report)) {
    res.message = "refused, nothing changed: the hair model cannot be rebuilt: " + why;
    return true;
  }
  if (rebuild) logImportReport(report);
  if (!rebuild) {
    // Stiffness, damping and curl weight live in the model as per-edge constants, and the new
    // constants (or a new substep) may put the explicit substep past its stability bound:
    // computed on a copy, committed below. Only parameter requests change model_, and they are
    // serialised.
    {
      std::lock_guard<std::mutex> lock(sim_mutex_);
      model = model_;
    }
    if (!updateSpringConstants(copy.solver, &model, &why)) {
      res.message = "refused, nothing changed: " + why;
      return true;
    }
  }
  const io::ObstacleMapConfig& old_map = scene_.obstacle_map;  // params_mutex_ keeps it
  const io::ObstacleMapConfig& new_map = copy.obstacle_map;
  const bool map_changed = old_map.file != new_map.file || old_map.offset_m != new_map.offset_m ||
                           old_map.resolution_m != new_map.resolution_m ||
                           old_map.margin_m != new_map.margin_m ||
                           old_map.unknown_is_occupied != new_map.unknown_is_occupied;
  std::string map_note;
  if (map_changed && !new_map.file.empty()) {
    if (!buildSceneMap(copy, &why)) {
      res.message = "refused, nothing changed: " + why;
      return true;
    }
    map_note = "; " + why;
  } else if (map_changed && !old_map.file.empty()) {
    std::lock_guard<std::mutex> lock(field_mutex_);
    field_remove_ = true;
    field_ready_ = false;
    map_note = "; obstacle_map.file is empty: the obstacle field is removed";
  } else if (map_changed) {
    map_note = "; the new obstacle_map settings apply to the next map (topic or service)";
  }
  // 3. Commit between two frames.
  {
    std::lock_guard<std::mutex> lock(sim_mutex_);
    scene_ = copy;
    obstacles_.analytic = scene_.obstacles;
    water_active_ = water_active_ || scene_.water.enabled;
    model_ = std::move(model);
    if (rebuild) {
      strands_skipped_ = static_cast<uint32_t>(report.skipped.size());
      resetHairLocked(head_pose_, "parameters changed the model");
    }
  }
  res.reset = rebuild;
  std::vector<std::string> changed_names = req.names;
  changed_names.insert(changed_names.end(), req.string_names.begin(), req.string_names.end());
  mirrorSceneToRos(pnh_, copy, changed_names);
  std::set<std::string> unique(changed_names.begin(), changed_names.end());
  std::string later;
  for (const std::string& n : unique) {
    if (n.rfind("saturation.", 0) == 0) later += " " + n + " acts at the next reset;";
    if (n.rfind("motion.", 0) == 0 || n.rfind("run.", 0) == 0)
      later += " " + n +
               " is used by the offline runner only (the node's head pose comes from "
               "tf2, its frame from ~publish_rate);";
  }
  res.success = true;
  res.message = "set " + std::to_string(unique.size()) + " parameter(s)" +
                (res.reset ? "; the hair model was rebuilt and the hair reset (saturation back to "
                             "the scene's initial ramp)"
                           : "; applied from the next frame") +
                map_note + (later.empty() ? "" : ";" + later);
  return true;
}

bool WetCurlyHairNode::onGetParameters(GetParameters::Request& req, GetParameters::Response& res) {
  res.success = false;
  std::lock_guard<std::mutex> lock(sim_mutex_);
  io::SceneConfig copy = scene_;
  const std::vector<ParamRef> table = parameterTable(&copy);
  std::vector<const ParamRef*> refs;
  if (req.names.empty()) {
    for (const ParamRef& r : table) refs.push_back(&r);
  } else {
    for (const std::string& n : req.names) {
      const ParamRef* ref = nullptr;
      for (const ParamRef& r : table)
        if (r.name == n) ref = &r;
      if (!ref) {
        res.message = io::unknownParameterMessage(n) + " (ask with no names for the full list)";
        return true;
      }
      refs.push_back(ref);
    }
  }
  for (const ParamRef* r : refs) {
    res.names.push_back(r->name);
    res.values.push_back(r->getAsDouble());
    res.string_values.push_back(r->valueString());
    const char* types[] = {"double", "int", "bool", "string"};
    res.types.push_back(types[static_cast<int>(r->type)]);
    res.docs.push_back(r->doc);
    res.needs_reset.push_back(r->needs_rebuild);
  }
  res.success = true;
  res.message = std::to_string(refs.size()) + " parameter(s)";
  return true;
}

bool WetCurlyHairNode::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<std::mutex> lock(sim_mutex_);
  resetHairLocked(head_pose_, "~reset service");
  res.success = true;
  res.message =
      "hair reset to its rest pose on the current head pose, saturation set to the "
      "scene's initial ramp (root " +
      fmt(scene_.saturation.root) + ", tip " + fmt(scene_.saturation.tip) +
      "); parameters and obstacles kept";
  return true;
}

}  // namespace wet_curly_hair
