// Helpers shared by the rostest gtest nodes: waiting for messages and services on wall time.
#pragma once

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <functional>
#include <mutex>
#include <string>

#include "wet_curly_hair/Status.h"
#include "wet_curly_hair/Strands.h"

namespace wch_test {

/// Keeps the newest message of a topic (thread-safe; callbacks run on an AsyncSpinner).
template <class M>
class Latest {
 public:
  Latest(ros::NodeHandle& nh, const std::string& topic) {
    sub_ = nh.subscribe<M>(topic, 50, &Latest::onMessage, this);
  }
  /// Unsubscribes first, so the spinner thread cannot call back into destroyed members.
  ~Latest() { sub_.shutdown(); }
  /// Waits (wall clock) for a message received after this call that satisfies pred.
  bool waitFor(double timeout_s, const std::function<bool(const M&)>& pred, M* out = nullptr) {
    uint64_t seen;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      seen = count_;
    }
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::ok() && ros::WallTime::now() < end) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (count_ > seen && msg_ && pred(*msg_)) {
          if (out) *out = *msg_;
          return true;
        }
      }
      ros::WallDuration(0.005).sleep();
    }
    return false;
  }
  bool next(double timeout_s, M* out) {
    return waitFor(
        timeout_s, [](const M&) { return true; }, out);
  }
  uint64_t count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return count_;
  }

 private:
  void onMessage(const typename M::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    msg_ = m;
    ++count_;
  }
  ros::Subscriber sub_;
  std::mutex mutex_;
  typename M::ConstPtr msg_;
  uint64_t count_ = 0;
};

/// Checks the size invariants of a Strands message; returns "" or what is wrong.
inline std::string strandsProblem(const wet_curly_hair::Strands& m) {
  if (m.strand_offsets.size() < 2) return "fewer than 2 strand offsets";
  if (m.strand_offsets.front() != 0) return "strand_offsets[0] != 0";
  for (size_t k = 1; k < m.strand_offsets.size(); ++k)
    if (m.strand_offsets[k] < m.strand_offsets[k - 1] + 2) return "a strand with < 2 particles";
  const size_t n = m.strand_offsets.back();
  if (m.positions.size() != 3 * n) return "positions.size() != 3 * particles";
  if (m.saturation.size() != n) return "saturation.size() != particles";
  if (!m.wet_positions.empty() && m.wet_positions.size() != 3 * n)
    return "wet_positions neither empty nor 3 * particles";
  if (m.header.frame_id.empty()) return "empty frame_id";
  return "";
}

template <class S>
bool call(ros::ServiceClient& client, S* srv) {
  if (!client.waitForExistence(ros::Duration(20.0))) return false;
  return client.call(*srv);
}

}  // namespace wch_test
