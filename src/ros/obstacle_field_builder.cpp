#include "wet_curly_hair/ros/obstacle_field_builder.h"

#include <sstream>

namespace wet_curly_hair {

ObstacleFieldBuilder::ObstacleFieldBuilder(Callback done) : done_(std::move(done)) {
  worker_ = std::thread([this] { run(); });
}

ObstacleFieldBuilder::~ObstacleFieldBuilder() {
  Callback dropped;
  Request dropped_request;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
    if (has_pending_) {
      dropped = pending_callback_;
      dropped_request = pending_;
      has_pending_ = false;
    }
  }
  wake_.notify_all();
  if (dropped) {
    Result r;
    r.superseded = true;
    r.message = "node shutting down: map from " + dropped_request.source + " not built";
    r.request = dropped_request;
    dropped(r);
  }
  worker_.join();
}

void ObstacleFieldBuilder::submit(const Request& request, Callback on_result) {
  Callback superseded;
  Request old;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (has_pending_) {
      superseded = pending_callback_;
      old = pending_;
    }
    pending_ = request;
    pending_callback_ = std::move(on_result);
    has_pending_ = true;
  }
  wake_.notify_all();
  if (superseded) {
    Result r;
    r.superseded = true;
    r.message = "superseded: a newer map (" + request.source + ") arrived before the map from " +
                old.source + " was built";
    r.request = old;
    superseded(r);
  }
}

bool ObstacleFieldBuilder::busy() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return has_pending_ || building_;
}

void ObstacleFieldBuilder::run() {
  for (;;) {
    Request request;
    Callback callback;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || has_pending_; });
      if (stop_) return;
      request = pending_;
      callback = std::move(pending_callback_);
      pending_callback_ = nullptr;
      has_pending_ = false;
      building_ = true;
    }
    Result r;
    r.request = request;
    auto sdf = std::make_shared<DenseSdf>();
    Pose sdf_in_world;
    std::string why;
    if (!request.tree) {
      r.message = "no tree";
    } else if (io::buildSdfFromOctree(*request.tree, request.tree_in_world, request.reach_box_world,
                                      request.config, sdf.get(), &sdf_in_world, &r.stats, &why)) {
      r.ok = true;
      r.field.sdf = sdf;
      r.field.field_in_world = sdf_in_world;
      std::ostringstream s;
      s << "built the obstacle field of " << request.source << ": " << r.stats.dims.x() << " x "
        << r.stats.dims.y() << " x " << r.stats.dims.z() << " voxels of "
        << request.config.resolution_m << " m (" << r.stats.occupied_cells << " occupied, "
        << r.stats.memory_bytes / 1024 << " KiB) in " << r.stats.total_s
        << " s; swapped in before the next frame";
      r.message = s.str();
    } else {
      r.message = "cannot build the obstacle field of " + request.source + ": " + why;
    }
    done_(r);
    if (callback) callback(r);
    std::lock_guard<std::mutex> lock(mutex_);
    building_ = false;
  }
}

}  // namespace wet_curly_hair
