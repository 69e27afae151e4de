#!/usr/bin/env bash
# The water demo (docs/water.md, "The demo"): config/scenes/water_demo.yaml run by the offline
# runner, its JSON series charted with gnuplot (held water, mean tip height, clump distance over
# time, the shower and dryer periods shaded) and frames every 2 s rendered as a contact sheet.
#   bench/water_demo.sh [OUT]      default OUT: docs/img (water_demo.json, _chart.png, _sheet.png)
set -eu
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bin=${WCH_BIN:-$root/_build/devel/lib/wet_curly_hair}
out=${1:-$root/docs/img}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"
"$bin/wet_curly_hair_run" --scene "$root/config/scenes/water_demo.yaml" --json "$tmp/run.json" \
  --hair-frames "$tmp/frames" --hair-stride 120 --series-stride 15 > /dev/null
/usr/bin/python3 - "$tmp/run.json" "$tmp/series.dat" "$out/water_demo.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
with open(sys.argv[2], "w") as f:
    for row in zip(d["time_s"], d["water_held_series_kg"], d["mean_tip_height_m"],
                   d["clump_distance_series_m"], d["mean_saturation"]):
        f.write(" ".join(repr(v) for v in row) + "\n")
keep = ["strands", "particles", "sim_s", "wall_s", "water_wall_s", "water_added_kg",
        "water_held_kg", "water_dripped_kg", "water_evaporated_kg", "water_removed_kg",
        "water_drips", "finite", "time_s", "mean_saturation", "water_held_series_kg",
        "mean_tip_height_m", "clump_distance_series_m"]
json.dump({k: d[k] for k in keep}, open(sys.argv[3], "w"), indent=1)
b = d["water_added_kg"] - d["water_removed_kg"] - d["water_held_kg"] - d["water_dripped_kg"] \
    - d["water_evaporated_kg"]
print("added %.4f kg = held %.4f + dripped %.4f + evaporated %.4f (+ removed %.4f); balance %.2e kg"
      % (d["water_added_kg"], d["water_held_kg"], d["water_dripped_kg"],
         d["water_evaporated_kg"], d["water_removed_kg"], b))
PY
gnuplot <<GP
set terminal pngcairo size 900,800 font ",11"
set output "$out/water_demo_chart.png"
set multiplot layout 3,1 title "Water demo: shower 2-7 s, dryer 10-22 s (150 strands, still head)"
set xrange [0:22]
set lmargin 10
set grid
set object 1 rect from 2, graph 0 to 7, graph 1 fc rgb "#cce0ff" fs solid 0.5 noborder behind
set object 2 rect from 10, graph 0 to 22, graph 1 fc rgb "#ffe0c0" fs solid 0.5 noborder behind
set ylabel "held water, g"
plot "$tmp/series.dat" using 1:(\$2*1000) with lines lw 2 lc rgb "#1f4e9c" notitle
set ylabel "mean tip height, cm"
plot "$tmp/series.dat" using 1:(\$3*100) with lines lw 2 lc rgb "#9c4e1f" notitle
set ylabel "clump distance, mm"
set xlabel "time, s"
# The clump distance is measured on wet particles: none before the shower.
plot "$tmp/series.dat" using 1:(\$5 > 0 ? \$4*1000 : 1/0) with lines lw 2 lc rgb "#2f7f2f" notitle
unset multiplot
GP
"$bin/wet_curly_hair_render" --sheet 6 --head --out "$out/water_demo_sheet.png" \
  --caption "water demo" "$tmp"/frames/frame_*.hair > /dev/null
echo "wrote $out/water_demo_chart.png $out/water_demo_sheet.png $out/water_demo.json"
