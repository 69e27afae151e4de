#!/usr/bin/env bash
# The node at 10,000 output strands (docs/followers.md, "10,000 strands"): what ~strands costs to
# build and publish at 60 Hz on wall-clock time, and whether the node keeps up.
#
#   bench/node_10k.sh [--seconds T] [--strands N] [--follow-ratio K] [--cohesion ours|off]
#                     [--gather-at all|guides] [--refresh S] [--status-only | --sink] [--obstacle SPEC]
#                     [--substep S] [--node-volumes true|false] [--nodelet] [--out DIR]
#
# Starts a private roscore, head_motion_publisher (the built-in nod, 120 Hz) and the node on the
# built-in scene (wet toward the tips) with N output strands of which N / K are guides, a sphere
# behind the head, ~publish_rate 60, ROS time = wall clock. A subscriber counts the ~strands
# messages that arrive and their serialized bytes over the last T seconds (after 5 s of warm-up)
# and keeps every ~status. Prints and writes OUT/node_10k.json: message bytes, messages received
# per wall second, the node's per-frame solver step, conversion (state -> messages), publish and
# head pose lookup (with its bounded wait for the pose) times (means over the status messages of
# the window), skipped frames in the window, solver and achieved real-time factors, and the CPU
# as the runner names it (its JSON's cpu, from one frame of one strand). Defaults: T = 20,
# N = 10000, K = 10, cohesion ours, the cohesion sums at every particle (--gather-at guides: at
# the guides only, solver.cohesion.gather_at), the display offsets evaluated every frame
# (--refresh S: at most every S s, solver.cohesion.refresh_period_s), the solver's substep
# 5e-4 s, the default (--substep S: solver.integrator.substep_s), the lattice's volumes at the
# particles (--node-volumes true: at its nodes, solver.cohesion.grid_node_volumes).
# --status-only: the probe subscribes to ~status alone, so ~strands has no
# subscriber and nothing receives its 9 MB per frame on this machine (a consumer on another
# machine, or none): the node's own capacity, without a local receiver competing for the cores.
# --sink: wet_curly_hair_strands_sink subscribes to ~strands instead of the probe, taking each
# message as raw bytes, so the node serializes and sends every frame as to any subscriber while
# the receiving costs this machine as little as it can; the probe counts what the sink took.
# --nodelet: the node runs as wet_curly_hair/WetCurlyHairNodelet in a nodelet manager, and with
# --sink the sink as wet_curly_hair/StrandsSinkNodelet in the same manager: the consumer takes
# each frame as the node's own message, neither serialized nor sent (docs/ros.md, "Nodelets").
set -eu
source "$(dirname "${BASH_SOURCE[0]}")/../scripts/setup_common.sh"
seconds=20 strands=10000 ratio=10 cohesion=ours gather_at=all refresh=0 status_only=0 sink=0
nodelet=0 out=node_10k_out
substep=0.0005 node_volumes=false
obstacle="sphere:x=-0.16,y=0.0,z=-0.05,r=0.05"
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds=$2; shift 2 ;;
    --strands) strands=$2; shift 2 ;;
    --follow-ratio) ratio=$2; shift 2 ;;
    --cohesion) cohesion=$2; shift 2 ;;
    --gather-at) gather_at=$2; shift 2 ;;
    --refresh) refresh=$2; shift 2 ;;
    --status-only) status_only=1; shift ;;
    --sink) sink=1; shift ;;
    --obstacle) obstacle=$2; shift 2 ;;
    --substep) substep=$2; shift 2 ;;
    --node-volumes) node_volumes=$2; shift 2 ;;
    --nodelet) nodelet=1; shift ;;
    --out) out=$2; shift 2 ;;
    *) echo "node_10k.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
mkdir -p "$out"
out=$(cd "$out" && pwd)
export PATH="/usr/bin:$PATH"
set +u
source "$WCH_BUILD/devel/setup.bash"
set -u
port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI="http://localhost:$port" ROS_HOSTNAME=localhost
export ROS_HOME="$out/ros_home" ROS_LOG_DIR="$out/ros_home/log"
mkdir -p "$ROS_LOG_DIR"
"$(wch_bin wet_curly_hair_run)" --strands 1 --seconds 0.0166667 --no-measure --json "$out/cpu.json" \
  > /dev/null
cpu=$(/usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["cpu"])' \
  "$out/cpu.json")
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  sleep 1
  for pid in "${pids[@]}"; do kill -TERM "$pid" 2>/dev/null || true; wait "$pid" 2>/dev/null || true; done
}
trap cleanup EXIT
roscore -p "$port" > "$out/roscore.log" 2>&1 &
pids+=($!)
for _ in $(seq 1 150); do rosnode list > /dev/null 2>&1 && break; sleep 0.2; done
rosparam set /wet_curly_hair/obstacles "[\"$obstacle\"]"
"$(wch_bin head_motion_publisher)" __name:=head_motion _motion:=nod _rate:=120 \
  > "$out/head.log" 2>&1 &
pids+=($!)
node_args=(__name:=wet_curly_hair _publish_rate:=60
  _groom/strands:="$strands" _groom/follow_ratio:="$ratio"
  _solver/cohesion/mode:="$cohesion" _solver/cohesion/gather_at:="$gather_at"
  _solver/cohesion/refresh_period_s:="$refresh" _solver/integrator/substep_s:="$substep"
  _solver/cohesion/grid_node_volumes:="$node_volumes")
if [ "$nodelet" = 1 ]; then
  rosrun nodelet nodelet manager __name:=wet_curly_hair_manager > "$out/manager.log" 2>&1 &
  pids+=($!)
  rosrun nodelet nodelet load wet_curly_hair/WetCurlyHairNodelet wet_curly_hair_manager "${node_args[@]}" \
    > "$out/node.log" 2>&1 &
  pids+=($!)
  if [ "$sink" = 1 ]; then
    rosrun nodelet nodelet load wet_curly_hair/StrandsSinkNodelet wet_curly_hair_manager __name:=strands_sink \
      > "$out/sink.log" 2>&1 &
    pids+=($!)
  fi
else
  "$(wch_bin wet_curly_hair_node)" "${node_args[@]}" > "$out/node.log" 2>&1 &
  pids+=($!)
  if [ "$sink" = 1 ]; then
    "$(wch_bin wet_curly_hair_strands_sink)" __name:=strands_sink > "$out/sink.log" 2>&1 &
    pids+=($!)
  fi
fi
if [ "$sink" = 1 ]; then status_only=1; fi  # the probe itself takes no strands
/usr/bin/python3 - "$out/node_10k.json" "$seconds" "$strands" "$ratio" "$cohesion" "$gather_at" "$refresh" "$status_only" "$substep" "$node_volumes" "$sink" "$nodelet" "$cpu" <<'PY'
import json, sys, time
import rospy
from std_msgs.msg import UInt64
from wet_curly_hair.msg import Status
path, seconds, strands, ratio, cohesion, gather_at = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5], sys.argv[6]
refresh, status_only, substep = float(sys.argv[7]), sys.argv[8] == "1", float(sys.argv[9])
node_volumes, sink, in_manager = sys.argv[10] == "true", sys.argv[11] == "1", sys.argv[12] == "1"
cpu = sys.argv[13]
rospy.init_node("node_10k_probe", anonymous=True)
window = {"on": False, "messages": 0, "bytes": [], "status": []}
def on_strands(msg):
    if window["on"]:
        window["messages"] += 1
        window["bytes"].append(len(msg._buff))
def on_status(msg):
    if window["on"]:
        window["status"].append(msg)
def on_sink(msg):
    if window["on"]:
        window["messages"] += 1
        window["bytes"].append(msg.data)
if sink:
    rospy.Subscriber("/strands_sink/received", UInt64, on_sink, queue_size=100)
elif not status_only:
    rospy.Subscriber("/wet_curly_hair/strands", rospy.AnyMsg, on_strands, queue_size=2, buff_size=1 << 26)
rospy.Subscriber("/wet_curly_hair/status", Status, on_status, queue_size=100)
deadline = time.time() + 300
while not rospy.is_shutdown() and time.time() < deadline:  # the model is built and frames flow
    try:
        rospy.wait_for_message("/wet_curly_hair/status", Status, timeout=5)
        break
    except rospy.ROSException:
        pass
time.sleep(5.0)
window["on"] = True
t0 = time.time()
time.sleep(seconds)
window["on"] = False
wall = time.time() - t0
st = [m for m in window["status"] if m.step_time_s > 0]
if not st or (not window["bytes"] and (sink or not status_only)):
    sys.exit("node_10k: no status or strands messages in the window")
mean = lambda xs: sum(xs) / len(xs)
first, last = window["status"][0], window["status"][-1]
r = {
    "cpu": cpu, "strands": strands, "follow_ratio": ratio, "cohesion": cohesion, "gather_at": gather_at,
    "refresh_period_s": refresh, "substep_s": substep, "node_volumes": node_volumes,
    "strands_subscribed": sink or not status_only,
    "consumer": ("sink nodelet" if in_manager else "sink") if sink else ("none" if status_only else "probe"),
    "node": "nodelet" if in_manager else "process",
    "particles": last.particles, "publish_rate_hz": 1.0 / last.frame_s,
    "window_wall_s": wall,
    "message_bytes": max(window["bytes"]) if window["bytes"] else 0,
    "messages_received_per_s": window["messages"] / wall,
    "received_mb_per_s": sum(window["bytes"]) / wall / 1e6,
    "step_time_s": mean([m.step_time_s for m in st]),
    "conversion_time_s": mean([m.conversion_time_s for m in st]),
    "publish_time_s": mean([m.publish_time_s for m in st]),
    "tf_lookup_time_s": mean([m.tf_lookup_time_s for m in st]),
    "solver_real_time_factor": mean([m.solver_real_time_factor for m in st]),
    "real_time_factor": mean([m.real_time_factor for m in window["status"]]),
    "skipped_frames_in_window": last.skipped_frames - first.skipped_frames,
    "frames_in_window": last.step - first.step,
}
json.dump(r, open(path, "w"), indent=1)
for k, v in r.items():
    print("%-26s %s" % (k, ("%.4g" % v) if isinstance(v, float) else v))
PY
