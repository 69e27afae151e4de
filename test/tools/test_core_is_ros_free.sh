#!/usr/bin/env bash
# The solver library, the file formats, the runner harness and the viewer must never include a
# ROS header: they are used and tested without a ROS installation (the runner, the benchmarks,
# the fuzz targets, the gtests).
set -u
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
hits=$(grep -rnE '#include *[<"](ros|tf2_ros|tf2|rosbag|roscpp|std_msgs|geometry_msgs|visualization_msgs)/' \
  include/wet_curly_hair/core include/wet_curly_hair/io include/wet_curly_hair/runner \
  include/wet_curly_hair/viewer src/core src/io src/runner src/viewer 2>/dev/null)
if [ -n "$hits" ]; then
  echo "ROS headers in the ROS-free core:"
  echo "$hits"
  echo "0 passed, 1 failed"
  exit 1
fi
echo "1 passed, 0 failed"
