#!/usr/bin/env bash
# The package installs and launches from a prefix: `cmake --install` of the build into a
# temporary prefix; then, in an environment that knows only that prefix (its setup.bash) and the
# system's ROS, `roslaunch wet_curly_hair wet_curly_hair.launch` on a private roscore (own port,
# own ROS_HOME) with a static head transform. The node must be the installed executable, load
# the installed libraries, and publish strands.
set -u
build=$(cd "$1" && pwd)
work=$(mktemp -d)
prefix=$work/prefix
pass=0 fail=0
check() { if eval "$2"; then pass=$((pass + 1)); else echo "FAIL: $1"; fail=$((fail + 1)); fi; }
trap 'rm -rf "$work"' EXIT

cmake --install "$build" --prefix "$prefix" > "$work/install.log" 2>&1
check "cmake --install succeeds (log: install.log)" "[ $? -eq 0 ] || { tail -20 $work/install.log; false; }"
for f in setup.bash _setup_util.py .catkin lib/libwet_curly_hair_core.so lib/libwet_curly_hair_io.so \
    lib/libwet_curly_hair_ros.so lib/libwet_curly_hair_runner.so lib/libwet_curly_hair_viewer.so \
    include/wet_curly_hair/core/solver.h include/wet_curly_hair/io/scene.h \
    include/wet_curly_hair/Strands.h include/wet_curly_hair/SetSaturation.h \
    share/wet_curly_hair/package.xml share/wet_curly_hair/launch_notes/wet_curly_hair.launch \
    share/wet_curly_hair/launch_notes/demo.launch share/wet_curly_hair/launch_notes/two_heads.launch \
    share/wet_curly_hair/launch_notes/head.launch share/wet_curly_hair/launch_notes/nodelet.launch \
    lib/libwet_curly_hair_nodelets.so share/wet_curly_hair/nodelet_plugins.xml \
    share/ament_index/resource_index/nodelet__pluginlib__plugin/wet_curly_hair \
    share/ament_index/resource_index/packages/wet_curly_hair \
    share/wet_curly_hair/config/default_node.yaml \
    share/wet_curly_hair/config/scenes/default.yaml share/wet_curly_hair/msg/Strands.msg \
    share/wet_curly_hair/srv/SetSaturation.srv share/wet_curly_hair/cmake/wet_curly_hairConfig.cmake \
    lib/python3/dist-packages/wet_curly_hair/srv/__init__.py; do
  check "installs $f" "[ -e $prefix/$f ]"
done
for f in wet_curly_hair_node head_motion_publisher wet_curly_hair_lockstep_clock wet_curly_hair_strands_sink \
    wet_curly_hair_wetting wet_curly_hair_bag_to_hair wet_curly_hair_run wet_curly_hair_render \
    wet_curly_hair_make_octomap; do
  check "installs lib/wet_curly_hair/$f" "[ -x $prefix/lib/wet_curly_hair/$f ]"
done

# Everything below runs with the prefix's environment only (no devel space, no source tree).
port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])')
cat > "$work/launch.sh" <<SH
source "$prefix/setup.bash"  # before set -u: the setup scripts read unset variables
set -u
export ROS_MASTER_URI=http://localhost:$port ROS_HOSTNAME=localhost
export ROS_HOME="$work/ros_home" ROS_LOG_DIR="$work/ros_home/log"
echo "package: \$(rospack find wet_curly_hair)"
echo "ament: \${AMENT_PREFIX_PATH:-}"
pids=()
stop() {  # SIGINT first (nodes clean up), then escalate
  for pid in "\${pids[@]}"; do kill -INT "\$pid" 2>/dev/null; done
  for pid in "\${pids[@]}"; do
    for _ in \$(seq 1 100); do kill -0 "\$pid" 2>/dev/null || break; sleep 0.1; done
    kill -TERM "\$pid" 2>/dev/null; wait "\$pid" 2>/dev/null
  done
}
trap stop EXIT
roscore -p $port > "$work/roscore.log" 2>&1 &
pids=(\$!)
for _ in \$(seq 1 150); do rosnode list > /dev/null 2>&1 && break; sleep 0.2; done
rosrun tf2_ros static_transform_publisher 0 0 0 0 0 0 world head > "$work/tf.log" 2>&1 &
pids=(\$! "\${pids[@]}")
roslaunch wet_curly_hair wet_curly_hair.launch output:=log > "$work/launch.log" 2>&1 &
pids=(\$! "\${pids[@]}")
timeout 60 rostopic echo -n 1 /wet_curly_hair/strands/strand_offsets > "$work/strands.txt" 2>&1
echo "echo: \$?"
pid=\$(timeout 10 rosnode info /wet_curly_hair 2>/dev/null | sed -n 's/^Pid: //p')
echo "exe: \$(readlink /proc/\$pid/exe)"
grep -o '/[^ ]*libwet_curly_hair_[a-z]*\.so' /proc/\$pid/maps | sort -u | sed 's/^/lib: /'
SH
env -i HOME="$HOME" PATH=/usr/bin:/bin bash "$work/launch.sh" > "$work/result.txt" 2>&1
check "rospack finds the installed package" \
  "grep -qx 'package: $prefix/share/wet_curly_hair' $work/result.txt"
check "the prefix's setup.bash puts it on AMENT_PREFIX_PATH (where pluginlib finds the nodelets)" \
  "grep -qE '^ament: (.*:)?$prefix(:.*)?\$' $work/result.txt"
check "the node publishes strands (rostopic echo -n 1 within 60 s)" \
  "grep -qx 'echo: 0' $work/result.txt && grep -q '\[0, ' $work/strands.txt"
check "the running node is the installed executable" \
  "grep -qx 'exe: $prefix/lib/wet_curly_hair/wet_curly_hair_node' $work/result.txt"
check "it loads the installed libraries only" \
  "[ \$(grep -c '^lib: $prefix/lib/' $work/result.txt) -ge 3 ] && ! grep '^lib: ' $work/result.txt | grep -vq '^lib: $prefix/lib/'"
cat "$work/result.txt"
if [ "$fail" -gt 0 ]; then
  tail -n 20 "$work/launch.log" "$work/strands.txt"
fi
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
