// Builds obstacle fields (OctoMap -> signed distance field over the box the hair can reach) on
// a worker thread, so the simulation keeps stepping with the previous field meanwhile. One build
// runs at a time; a request arriving during a build waits, and a newer one replaces it (the
// replaced request is answered "superseded").
#pragma once

#include <octomap/OcTree.h>

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "wet_curly_hair/core/obstacles.h"
#include "wet_curly_hair/io/octomap_sdf.h"

namespace wet_curly_hair {

class ObstacleFieldBuilder {
 public:
  struct Request {
    std::shared_ptr<const octomap::OcTree> tree;
    Pose tree_in_world;                   ///< world <- map frame.
    Eigen::AlignedBox3d reach_box_world;  ///< where the hair can be, world frame, m.
    io::SdfBuildConfig config;            ///< voxel size, margin, unknown space.
    std::string source;                   ///< for messages: file path or topic.
    double map_stamp_s = 0.0;             ///< ROS time of the map, s.
  };
  struct Result {
    bool ok = false;
    bool superseded = false;  ///< dropped unbuilt: a newer request replaced it (or shutdown).
    std::string message;      ///< what was built, or why not.
    ObstacleField field;      ///< valid when ok.
    io::SdfBuildStats stats;
    Request request;  ///< what was built (the tree is kept for rebuilds).
  };
  using Callback = std::function<void(const Result&)>;

  /// `done` is called on the worker thread after every request that was built or refused (not
  /// for superseded ones).
  explicit ObstacleFieldBuilder(Callback done);
  ~ObstacleFieldBuilder();  ///< finishes the running build, drops the pending one, joins.
  ObstacleFieldBuilder(const ObstacleFieldBuilder&) = delete;
  ObstacleFieldBuilder& operator=(const ObstacleFieldBuilder&) = delete;

  /// Queues a build. `on_result` (may be empty) is called for this request only, after `done`.
  void submit(const Request& request, Callback on_result);
  /// True while a build runs or waits.
  bool busy() const;

 private:
  void run();

  const Callback done_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool has_pending_ = false;
  bool building_ = false;
  bool stop_ = false;
  Request pending_;
  Callback pending_callback_;
  std::thread worker_;
};

}  // namespace wet_curly_hair
