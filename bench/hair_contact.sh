#!/usr/bin/env bash
# Hair-hair contact measured (docs/hair_contact.md): the built-in groom (200 curly strands of 32,
# wet 0.8) on a still head and under a spin, a nod and a shake, contact off and on: crossings
# between frames, the groom's volume (mean particle distance from the head surface, last frame
# and over the run), and the cost of the contact stage against the rest of the step; then the
# cost at 100, 1,000 and 10,000 strands (short runs); and a before/after picture of the spin's
# last frame.
#   bench/hair_contact.sh [OUT]   default OUT: docs/bench (hair_contact.csv, hair_contact_cost.csv,
#                                 and hair_contact_sheet.png in docs/img)
# One solver thread, so that the ratios do not depend on what else the machine runs.
set -eu
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bin=${WCH_BIN:-$root/_build/devel/lib/wet_curly_hair}
out=${1:-$root/docs/bench}
img=${WCH_IMG:-$root/docs/img}
seconds=${WCH_CONTACT_SECONDS:-2}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out" "$img"
run() {  # name motion contact [extra...]
  local name=$1 motion=$2 contact=$3
  shift 3
  "$bin/wet_curly_hair_run" --seconds "$seconds" --motion "$motion" --saturation 0.8,0.8 \
    --threads 1 --hair-contact "$contact" --crossings --json "$tmp/$name.json" "$@" > /dev/null
}
for motion in still spin:rate_hz=1 nod shake; do
  m=${motion%%:*}
  for contact in off on; do
    frames=()
    [ "$m" = spin ] && frames=(--hair-frames "$tmp/frames_$contact" --hair-stride 30)
    run "${m}_$contact" "$motion" "$contact" "${frames[@]}"
  done
done
# The runner names the CPU (its JSON's cpu: name, family and model, avx512f).
cpu=$(/usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["cpu"])' \
  "$tmp/still_off.json")
/usr/bin/python3 - "$tmp" "$out/hair_contact.csv" "$cpu" "$seconds" <<'PY'
import json, sys
tmp, csv, cpu, seconds = sys.argv[1:]
rows = []
for m in ["still", "spin", "nod", "shake"]:
    for c in ["off", "on"]:
        d = json.load(open("%s/%s_%s.json" % (tmp, m, c)))
        st = d["stages"]
        contact_s = st["hair_contact"]["cpu_s"]
        step_s = sum(v["cpu_s"] for v in st.values())
        late = int(sum(d["crossings_series"][15:]))  # after the first 0.25 s
        rows.append([m, c, d["crossings"], d["crossings"] - late, late,
                     d["max_crossings_per_frame"], d["tangles_sim"],
                     d["mean_head_distance_m"] * 1e3, d["mean_head_distance_run_m"] * 1e3,
                     d["hair_contacts"], d["hair_contact_list_builds"],
                     d["wall_s"] / d["sim_s"], contact_s / d["sim_s"],
                     (step_s - contact_s) / d["sim_s"], d["repairs"], d["max_strain"]])
with open(csv, "w") as f:
    f.write("# %s, 1 thread, %s s, 200 strands x 32, saturation 0.8\n" % (cpu, seconds))
    f.write("motion,contact,crossings,crossings_first_0.25s,crossings_after_0.25s,"
            "max_crossings_per_frame,touching_segments_end,"
            "head_distance_end_mm,head_distance_run_mm,hair_contacts_end,list_builds,"
            "step_s_per_s,contact_s_per_s,other_stages_s_per_s,repairs,max_strain\n")
    for r in rows:
        f.write(",".join(("%.4g" % v) if isinstance(v, float) else str(v) for v in r) + "\n")
print(open(csv).read())
PY
# Cost at 100, 1,000 and 10,000 strands (still head, wet; contact stage against the rest).
{
  echo "# $cpu, 1 thread, still head, saturation 0.8"
  echo "strands,radius_m,contact,sim_s,step_s_per_s,contact_s_per_s,other_stages_s_per_s,hair_contacts_end,list_builds,overflows"
} > "$out/hair_contact_cost.csv"
# The radius follows the strand density (a strand stands for a wisp of 1/strands of the hair):
# r = 4 mm sqrt(200 / strands); at 1,000 strands the default 4 mm too.
for n in 100 1000 10000 1000d; do
  strands=${n%d}
  secs=$(/usr/bin/python3 -c "print({100: 1.0, 1000: 0.25, 10000: 0.05}[$strands])")
  r=$(/usr/bin/python3 -c "import math; print(0.004 if '$n'.endswith('d') else 0.004 * math.sqrt(200 / $strands))")
  for contact in off on; do
    [ "$n" = 1000d ] && [ "$contact" = off ] && continue
    "$bin/wet_curly_hair_run" --strands "$strands" --seconds "$secs" --motion still \
      --saturation 0.8,0.8 --threads 1 --hair-contact "$contact" --no-crossings --no-tangles \
      --no-clump-distance --set solver.hair_contact.radius_m="$r" --json "$tmp/cost.json" > /dev/null
    /usr/bin/python3 - "$tmp/cost.json" "$strands" "$contact" "$r" >> "$out/hair_contact_cost.csv" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
st = d["stages"]
c = st["hair_contact"]["cpu_s"]
step = sum(v["cpu_s"] for v in st.values())
print("%s,%s,%s,%g,%.4g,%.4g,%.4g,%d,%d,%d" % (sys.argv[2], sys.argv[4], sys.argv[3],
      d["sim_s"], d["wall_s"] / d["sim_s"], c / d["sim_s"], (step - c) / d["sim_s"],
      d["hair_contacts"], d["hair_contact_list_builds"], d["hair_contact_overflows"]))
PY
  done
done
cat "$out/hair_contact_cost.csv"
# Before / after: the spin's last frame, contact off and on.
if [ -x "$bin/wet_curly_hair_render" ]; then
  "$bin/wet_curly_hair_render" --sheet 2 --head --view 1,0.55,0.3 \
    --caption "spin 1 rev/s, wet" \
    --out "$img/hair_contact_sheet.png" "$(ls "$tmp"/frames_off/*.hair | tail -1)" \
    "$(ls "$tmp"/frames_on/*.hair | tail -1)"
fi
