#!/usr/bin/env bash
# Long run (docs/long_run.md): one simulated hour of spin-and-nod on the built-in scene, recording
# strand length drift, repairs, memory and the real-time factor per simulated minute.
#
#   bench/long_run.sh [BUILD_DIR] [--seconds T] [--strands N] [--integrator NAME] [--substep S]
#                     [--out DIR] [--threads N]
#
# Defaults: BUILD_DIR _build, T = 3600 s, 20 strands x 32 particles, theta (0.6) at 1/240 s,
# 1 thread, OUT = long_run_out/. The runner has no combined motion, so the head spins at
# 0.5 rev/s about an axis tilted 30 degrees from the vertical toward the face (axis (0.577, 0, 1)):
# the head turns, and its crown dips 30 degrees forward, sideways and back once per turn: a spin
# and a nod in one motion, for the whole hour. Everything else is the built-in scene (soft curly
# hair, saturation 0 -> 0.8 root to tip, cohesion on, head ellipsoid and neck).
#
# Writes OUT/long_run.json (the runner's JSON: energy every simulated second, the real-time factor
# per simulated minute in realtime_factor_windows, rss_*_kb, strain and strand extension at the
# start and the end), OUT/time.txt (/usr/bin/time -v) and OUT/long_run.md (the summary).
set -eu
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$here/_build"
if [ $# -gt 0 ] && [ "${1#--}" = "$1" ]; then build=$1; shift; fi
seconds=3600 strands=20 integrator=theta substep=0.004166666666666667 out=long_run_out threads=1
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds=$2; shift 2 ;;
    --strands) strands=$2; shift 2 ;;
    --integrator) integrator=$2; shift 2 ;;
    --substep) substep=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    *) echo "long_run.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
run=$(find "$build" -name wet_curly_hair_run -type f -perm -u+x | head -1)
[ -n "$run" ] || { echo "long_run.sh: no wet_curly_hair_run under $build" >&2; exit 2; }
mkdir -p "$out"
cmd=("$run" --strands "$strands" --seconds "$seconds"
     --motion spin:rate_hz=0.5,axis_x=0.577,axis_y=0,axis_z=1
     --integrator "$integrator" --substep "$substep" --threads "$threads"
     --series-stride 60 --rtf-window 60 --json "$out/long_run.json")
echo "running: ${cmd[*]}"
start=$(date +%s)
/usr/bin/time -v "${cmd[@]}" > /dev/null 2> "$out/time.txt" || { tail "$out/time.txt"; exit 1; }
end=$(date +%s)
/usr/bin/python3 - "$out" "$((end - start))" "${cmd[*]}" <<'PY'
import json, re, sys
out, wall, cmd = sys.argv[1], int(sys.argv[2]), sys.argv[3]
d = json.load(open(out + "/long_run.json"))
tv = open(out + "/time.txt").read()
max_rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", tv).group(1))
w = d["realtime_factor_windows"]
E = d["energy"]
lines = [
    "Long run: %g simulated s, %d strands x %d particles, %s at %.6g s substeps, %d thread(s); "
    "%d s of wall time in all." % (d["sim_s"], d["strands"], d["particles"] // max(1, d["strands"]),
                                  d["integrator"], d["substep_s"], d["threads"], wall),
    "",
    "| figure | value |", "|---|---|",
    "| repairs (strands restored) | %d |" % d["repairs"],
    "| every value finite | %s |" % d["finite"],
    "| max edge strain: first frame / last frame / any frame | %.4g / %.4g / %.4g |" % (
        d["max_strain_start"], d["max_strain_end"], d["max_strain"]),
    "| mean abs edge strain: first frame / last frame / over the run | %.4g / %.4g / %.4g |" % (
        d["mean_strain_start"], d["mean_strain_end"], d["mean_strain"]),
    "| max strand extension (arc length / rest - 1): first / last / any frame (>= 0) | %.4g / %.4g / %.4g |" % (
        d["max_strand_extension_start"], d["max_strand_extension_end"], d["max_strand_extension"]),
    "| mean strand extension: first / last frame | %.4g / %.4g |" % (
        d["mean_strand_extension_start"], d["mean_strand_extension_end"]),
    "| max strain before limiting | %.4g |" % d["max_strain_before_limit"],
    "| resident memory: before the model / at the end / peak (VmHWM) | %d / %d / %d kB |" % (
        d["rss_start_kb"], d["rss_end_kb"], d["rss_peak_kb"]),
    "| max RSS (/usr/bin/time -v) | %d kB |" % max_rss,
    "| real-time factor (step only): whole run | %.3g |" % d["realtime_factor"],
    "| real-time factor per simulated minute: first / last / min / max | %.3g / %.3g / %.3g / %.3g |" % (
        w[0], w[-1], min(w), max(w)),
    "| total energy, J: t = 0 / first minute mean / last minute mean | %.4g / %.4g / %.4g |" % (
        E[0], sum(E[1:61]) / len(E[1:61]), sum(E[-60:]) / len(E[-60:])),
    "",
    "Real-time factor per simulated minute: " + ", ".join("%.3g" % x for x in w),
    "",
    "Command: `%s`" % cmd.replace(out + "/", "OUT/"),
]
text = "\n".join(lines) + "\n"
open(out + "/long_run.md", "w").write(text)
print(text)
PY
