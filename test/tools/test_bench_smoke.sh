#!/usr/bin/env bash
# Smoke run of the speed-against-error benchmark (bench/wet_curly_hair_bench.cpp) so it cannot
# rot: a handful of settings on tiny scenes. No timing assertions: the machines are shared.
set -u
build=$1
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
bench=$(tool_path wet_curly_hair_bench "$build") || exit 1
run=$(tool_path wet_curly_hair_run "$build") || exit 1
require_command gnuplot gnuplot-nox
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
pass=0 fail=0
check() { if eval "$2"; then pass=$((pass + 1)); else echo "FAIL: $1"; fail=$((fail + 1)); fi; }

"$bench" --quick --out "$out/b" > "$out/stdout" 2> "$out/stderr"
# The bench's own status, taken before anything else runs (a $(...) in check's arguments would
# replace $? with its own).
bench_rc=$?
check "runs and exits 0 (got $bench_rc; stderr: $(head -c 300 "$out/stderr"))" "[ $bench_rc -eq 0 ]"
check "writes work_precision.csv, reference.csv, scaling.csv, gating.csv and cohesion.csv (exact, the gathers, the node sums, auto as the gathers on 6 strands)" \
  "[ -s $out/b/work_precision.csv ] && [ -s $out/b/reference.csv ] && [ -s $out/b/scaling.csv ] && [ \$(wc -l < $out/b/gating.csv) -eq 5 ] && [ \$(wc -l < $out/b/cohesion.csv) -eq 5 ] && grep -q ',grid,4,nodes,' $out/b/cohesion.csv && grep -q ',grid,3,auto,grid3 particles,' $out/b/cohesion.csv"
# The built-in scene as shipped: one row with the defaults' integrator and a real-time factor.
check "builtin.csv: the shipped scene at the defaults, a positive real-time factor" "/usr/bin/python3 - <<PY
import csv, sys
rows = list(csv.DictReader(open('$out/b/builtin.csv')))
ok = len(rows) == 1 and rows[0]['scene'] == 'builtin' and rows[0]['integrator'] in ('explicit', 'backward_euler', 'theta', 'midpoint')
ok = ok and rows[0]['strands'] == '200' and float(rows[0]['realtime_factor']) > 0
sys.exit(0 if ok else 1)
PY"
# Every quick setting of every scene: finite cost and error, stable, and the reference converged
# far below the errors it measures.
check "work-precision rows complete, stable, errors finite and positive" "/usr/bin/python3 - <<PY
import csv, math, sys
rows = list(csv.DictReader(open('$out/b/work_precision.csv')))
ok = len(rows) == 5 * 3
for r in rows:
    ok = ok and r['stable'] == '1' and float(r['wall_s_per_sim_s']) > 0
    ok = ok and 0 < float(r['rms_error']) <= float(r['max_error']) < 1 and math.isfinite(float(r['max_error']))
ref = {r['scene']: float(r['rms_difference']) for r in csv.DictReader(open('$out/b/reference.csv'))}
ok = ok and len(ref) == 5
for r in rows:
    ok = ok and ref[r['scene']] < 0.1 * float(r['rms_error'])
sys.exit(0 if ok else 1)
PY"
# The target scene: the reference converged below the error it measures, the strand lanes
# (float by default) give the error of one strand at a time (same dynamics in double) within
# 1 % of it, the full model's rows (exact and lattice cohesion) have output-position errors, and
# every row has its shape distances.
check "target rows: candidates stable, lanes and per-strand errors equal, full-model errors, shape distances" "/usr/bin/python3 - <<PY
import csv, math, sys
rows = list(csv.DictReader(open('$out/b/target.csv')))
ref = [r for r in rows if r['integrator'] == 'reference_check']
ref_out = [r for r in rows if r['integrator'] == 'reference_check_output']
runs = [r for r in rows if not r['integrator'].startswith('reference_check')]
ok = len(ref) == 1 and len(ref_out) == 1 and len(runs) == 4 and all(r['stable'] == '1' for r in runs)
err = [float(r['rms_error']) for r in runs if r['cohesion'] == 'off']
ok = ok and len(err) == 2 and abs(err[0] - err[1]) <= 1e-2 * err[0]
ok = ok and float(ref[0]['rms_error']) < 0.1 * err[0]
full = [r for r in runs if r['cohesion'] != 'off']
ok = ok and sorted(r['cohesion'] for r in full) == ['exact', 'grid4']
ok = ok and all(0 < float(r['rms_error']) <= float(r['max_error']) < 1 for r in full)
# Shape distances on every row: the two references' too (the floor), Wasserstein-1 finite and
# non-negative, Kolmogorov-Smirnov in [0, 1].
for r in rows:
  for s in ('tip_height', 'curl_radius', 'clump_distance'):
    w1, ks = float(r[s + '_w1_m']), float(r[s + '_ks'])
    ok = ok and math.isfinite(w1) and w1 >= 0 and 0 <= ks <= 1
sys.exit(0 if ok else 1)
PY"
# Float or double: every lane layout ran the target scene's dynamics, stable, and float's error
# against the reference is the double one's within 1 % (float's own part is far smaller than
# the step's).
check "lanes rows: four layouts, stable, float errors within 1 % of double's" "/usr/bin/python3 - <<PY
import csv, sys
rows = list(csv.DictReader(open('$out/b/lanes.csv')))
ok = sorted(r['lane_layout'] for r in rows) == ['double4', 'double8', 'float16', 'float8']
ok = ok and all(r['stable'] == '1' and float(r['wall_s_per_sim_s']) > 0 for r in rows)
e = {r['lane_layout']: float(r['rms_error']) for r in rows}
ok = ok and e['double8'] == e['double4'] and all(abs(e[k] - e['double4']) <= 0.01 * e['double4'] for k in e)
sys.exit(0 if ok else 1)
PY"
check "scaling rows for 1 and 2 threads" \
  "[ \$(grep -c ',1,' $out/b/scaling.csv) -ge 2 ] && [ \$(grep -c ',2,' $out/b/scaling.csv) -ge 2 ]"
check "draws the charts" "[ -s $out/b/work_precision.png ] && [ -s $out/b/scaling.png ] && [ -s $out/b/lanes.png ]"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
/usr/bin/python3 "$here/bench/bench_summary.py" "$out/b" > /dev/null 2> "$out/summary_err"
check "bench_summary.py writes the budget, scaling and gating tables ($(head -c 300 "$out/summary_err"))" \
  "grep -q 'RMS error at most 1 %' $out/b/summary.md && grep -q '^## Scaling' $out/b/summary.md && grep -q '| theta | wet |' $out/b/summary.md && grep -q '^## Target scene' $out/b/summary.md && grep -q '^Shape distributions over the whole run' $out/b/summary.md && grep -q '^## Float or double' $out/b/summary.md && grep -q '^## Built-in scene at the defaults' $out/b/summary.md"
rm -f "$out/b/scaling.png"
"$bench" --replot --out "$out/b" > /dev/null 2>&1
check "--replot redraws the charts from the CSV files" "[ -s $out/b/scaling.png ]"
# A point of the chart reproduces by hand with the runner's flags.
"$run" --seconds 0.2 --strands 6 --integrator theta --substep 0.0041666667 --threads 2 \
  --json "$out/p.json" > /dev/null 2>&1
check "runner takes --integrator --substep --threads, reports the lane layout" "/usr/bin/python3 -c \"import json,sys; d=json.load(open('$out/p.json')); sys.exit(0 if d['integrator']=='theta' and d['lane_layout'] in ('float8','float16') and d['threads']==2 and abs(d['substep_s']-1/240)<1e-9 and d['stages']['integrate']['particles']>0 else 1)\""
"$run" --integrator rk4 > /dev/null 2> "$out/err"
check "unknown integrator refused by name" "grep -q 'solver.integrator.method' $out/err"
# The measurements' cost (bench/bench_measurements.cpp) runs and prints the share of the stepping
# and the runner's clump distance and tangles against the exact ones (60 strands: exact here).
measure=$(tool_path bench_measurements "$build") || exit 1
"$measure" --strands 60 --seconds 0.1 --runs 1 > "$out/measure.txt" 2>&1
measure_rc=$?
check "bench_measurements runs (got $measure_rc)" "[ $measure_rc -eq 0 ]"
check "bench_measurements reports the share of the stepping and the exact figures" \
  "grep -q '% of stepping (median)' $out/measure.txt && grep -q 'tangles .* against .* exact' $out/measure.txt"
# The water stage's cost (bench/bench_water.cpp) runs and prints its share of the dynamics.
water=$(tool_path bench_water "$build") || exit 1
"$water" --strands 20 --frames 3 > "$out/water.txt" 2>&1
water_rc=$?
check "bench_water runs (got $water_rc)" "[ $water_rc -eq 0 ]"
check "bench_water reports the water stage's share of the dynamics" \
  "grep -q 'CPU: ' $out/water.txt && grep -q '% of the dynamics' $out/water.txt"
# The follower placement alone (bench/bench_follower_placement.cpp) runs, reports ns per follower
# particle with the CPU, times the display pass alone per output particle with --stage display,
# hashes each stage's output the same on 1 and 3 threads, and refuses a follow ratio without
# followers and an unknown stage.
placement=$(tool_path bench_follower_placement "$build") || exit 1
"$placement" --strands 40 --follow-ratio 4 --warm-frames 2 --runs 3 > "$out/placement.txt" 2>&1
placement_rc=$?
check "bench_follower_placement runs (got $placement_rc)" "[ $placement_rc -eq 0 ]"
check "bench_follower_placement reports the CPU and the time per follower particle" \
  "grep -q 'no avx512f\|, avx512f' $out/placement.txt && grep -q '(960 follower particles), placement, .*ns per particle' $out/placement.txt"
"$placement" --strands 40 --follow-ratio 4 --warm-frames 2 --runs 3 --stage display \
  --gather-at guides > "$out/display.txt" 2>&1
placement_rc=$?
check "bench_follower_placement --stage display runs (got $placement_rc)" "[ $placement_rc -eq 0 ]"
check "bench_follower_placement --stage display reports the time per output particle" \
  "grep -q '(1280 output particles), display pass, sums at guides, .*ns per particle' $out/display.txt"
"$placement" --strands 40 --follow-ratio 4 --warm-frames 2 --runs 3 --stage display \
  --gather-at guides --node-volumes true > "$out/display_nv.txt" 2>&1
placement_rc=$?
check "bench_follower_placement --node-volumes true runs (got $placement_rc)" \
  "[ $placement_rc -eq 0 ] && grep -q 'display pass, sums at guides, .*ns per particle' $out/display_nv.txt"
"$placement" --strands 40 --follow-ratio 4 --warm-frames 2 --runs 3 --stage display \
  --wet-sums nodes --cells 4 > "$out/display_nodes.txt" 2>&1
placement_rc=$?
check "bench_follower_placement --wet-sums nodes --cells 4 names the lattice it ran (got $placement_rc)" \
  "[ $placement_rc -eq 0 ] && grep -q 'sums at all, nodes: at the nodes, 4 nodes per radius, .*ns per particle' $out/display_nodes.txt"
# The output hash (FNV-1a of the positions' bytes) is what a change meant to move nothing is
# checked with: every thread count must print the same, on both lattice paths and the placement.
output_hashes() {  # $1: threads; prints one hash per stage run
  local threads=$1
  for stage in "--stage placement" "--stage display" "--stage display --wet-sums nodes"; do
    # shellcheck disable=SC2086
    "$placement" --strands 40 --follow-ratio 4 --warm-frames 2 --runs 1 --threads "$threads" \
      $stage | sed -n 's/^output hash \([0-9a-f]\{16\}\) .*/\1/p'
  done
}
hashes_1=$(output_hashes 1 | tr '\n' ' ')
hashes_3=$(output_hashes 3 | tr '\n' ' ')
check "bench_follower_placement hashes its output the same on 1 and 3 threads (got '$hashes_1' and '$hashes_3')" \
  "[ \$(echo '$hashes_1' | wc -w) -eq 3 ] && [ '$hashes_1' = '$hashes_3' ]"
"$placement" --follow-ratio 1 > /dev/null 2> "$out/placement_err"
placement_rc=$?
check "bench_follower_placement refuses --follow-ratio 1 (got $placement_rc)" \
  "[ $placement_rc -eq 2 ] && grep -q 'follow-ratio K > 1' $out/placement_err"
"$placement" --stage splat > /dev/null 2> "$out/placement_err"
placement_rc=$?
check "bench_follower_placement refuses an unknown stage (got $placement_rc)" \
  "[ $placement_rc -eq 2 ] && grep -q 'stage placement|display' $out/placement_err"
# The lattice's error against exact (bench/bench_lattice_error.cpp) runs and reports it for both
# volumes, and refuses a single frame.
lattice=$(tool_path bench_lattice_error "$build") || exit 1
"$lattice" --strands 60 --follow-ratio 4 --frames 12 > "$out/lattice.txt" 2>&1
lattice_rc=$?
check "bench_lattice_error runs (got $lattice_rc)" "[ $lattice_rc -eq 0 ]"
check "bench_lattice_error reports both volumes' errors" \
  "grep -q '^particle volumes: simulated strands RMS .* mm, max .*followers RMS' $out/lattice.txt && grep -q '^node volumes: ' $out/lattice.txt && grep -q 'exact offset' $out/lattice.txt"
"$lattice" --frames 1 > /dev/null 2> "$out/lattice_err"
lattice_rc=$?
check "bench_lattice_error refuses --frames 1 (got $lattice_rc)" \
  "[ $lattice_rc -eq 2 ] && grep -q 'frames F >= 2' $out/lattice_err"
# The README's 10,000-strand runner commands (bench/targets_10k.py) on a small groom: both
# targets run, every run is in the CSV under the runner's CPU line, and bad counts are refused.
/usr/bin/python3 "$here/bench/targets_10k.py" --build "$build" --strands 24 --seconds 0.05 \
  --runs 2 --out "$out/targets" > "$out/targets.txt" 2>&1
targets_rc=$?
check "targets_10k.py runs (got $targets_rc; $(tail -c 300 "$out/targets.txt"))" \
  "[ $targets_rc -eq 0 ]"
check "targets_10k.py names the lanes the build chose for the CPU and the lattice that ran" \
  "grep -Eq 'lanes float(8|16), lattice floats (8|16); cohesion grid[34], sums at the (particles|nodes)\$' $out/targets.txt"
check "targets_10k.py prints both targets' medians and writes every run" \
  "grep -q '^simulated_theta_240 .*RTF median' $out/targets.txt && grep -q '^defaults_follow_ratio_10 .*RTF median' $out/targets.txt && [ \$(grep -c ',[12],' $out/targets/targets_10k.csv) -eq 4 ] && head -1 $out/targets/targets_10k.csv | grep -q 'avx512f'"
# The ratio of the medians, as printed, from the medians as printed (each rounded to 3 decimals).
ratio_check=$(awk '/^simulated_theta_240 .*RTF median/ {a = $4} /^defaults_follow_ratio_10 .*RTF median/ {b = $4}
  /^defaults_follow_ratio_10 \/ simulated_theta_240: / {r = $4}
  END {d = b / a - r; if (a > 0 && r != "" && d < 0.006 && d > -0.006) print "ok"}' "$out/targets.txt")
check "targets_10k.py prints the ratio of the two targets' medians" "[ '$ratio_check' = ok ]"
/usr/bin/python3 "$here/bench/targets_10k.py" --build "$build" --runs 0 > /dev/null \
  2> "$out/targets_err"
targets_rc=$?
check "targets_10k.py refuses --runs 0 (got $targets_rc)" \
  "[ $targets_rc -eq 2 ] && grep -q 'at least 1' $out/targets_err"
# Two builds taking turns (bench/paired_runs.py), here the same build on both sides: every pair
# printed and written, the median of the pairs' ratios as printed from the ratios printed, and a
# runner that refuses its arguments named with what it said.
/usr/bin/python3 "$here/bench/paired_runs.py" --baseline "$build" --build "$build" --pairs 3 \
  --out "$out/paired" -- --strands 24 --seconds 0.05 --threads 1 --no-measure \
  > "$out/paired.txt" 2>&1
paired_rc=$?
check "paired_runs.py runs (got $paired_rc; $(tail -c 300 "$out/paired.txt"))" "[ $paired_rc -eq 0 ]"
check "paired_runs.py prints both sides and writes every run" \
  "grep -q '^baseline RTF median' $out/paired.txt && grep -q '^build    RTF median' $out/paired.txt && [ \$(grep -c ',baseline,' $out/paired/paired_runs.csv) -eq 3 ] && [ \$(grep -c ',build,' $out/paired/paired_runs.csv) -eq 3 ]"
check "paired_runs.py prints the median of the pairs' ratios" "/usr/bin/python3 - <<PY
import re, statistics, sys
line = [l for l in open('$out/paired.txt') if l.startswith('build / baseline')][0]
ratios = [float(x) for x in re.search(r'per pair: ([0-9. ]+);', line).group(1).split()]
median = float(re.search(r'median ([0-9.]+)x', line).group(1))
sys.exit(0 if len(ratios) == 3 and abs(statistics.median(ratios) - median) < 1e-3 else 1)
PY"
/usr/bin/python3 "$here/bench/paired_runs.py" --baseline "$build" --build "$build" --pairs 1 -- \
  --strands -3 > /dev/null 2> "$out/paired_err"
paired_rc=$?
check "paired_runs.py names a runner that refused its arguments (got $paired_rc)" \
  "[ $paired_rc -eq 2 ] && grep -q \"runner failed: .*strands\" $out/paired_err"
# --out: a missing directory is made with its parents; a file in the way is refused by name,
# before any run, instead of every table and chart being lost.
followers=$(tool_path bench_followers "$build") || exit 1
"$followers" --strands 50 --ks 2 --seconds 0.05 --runs 1 --out "$out/new/nested" > /dev/null 2>&1
followers_rc=$?
check "bench_followers makes a missing --out directory (got $followers_rc)" \
  "[ $followers_rc -eq 0 ] && [ -s $out/new/nested/followers.csv ]"
touch "$out/a_file"
"$bench" --quick --out "$out/a_file" > /dev/null 2> "$out/out_err"
out_rc=$?
check "wet_curly_hair_bench refuses a file as --out (got $out_rc)" \
  "[ $out_rc -eq 2 ] && grep -q 'cannot use --out .*a_file' $out/out_err && [ ! -s $out/a_file ]"
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
