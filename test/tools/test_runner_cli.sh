#!/usr/bin/env bash
# The runner's command line: documented options work, bad ones fail with a message and exit 2.
set -u
build=$1
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
run=$(tool_path wet_curly_hair_run "$build") || exit 1
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
pass=0 fail=0
check() { if eval "$2"; then pass=$((pass + 1)); else echo "FAIL: $1"; fail=$((fail + 1)); fi; }

"$run" --seconds 0.2 --strands 5 --particles 16 --motion spin:rate_hz=1 --json "$out/a.json" \
  --hair-frames "$out/frames" --hair-stride 6 > "$out/stdout" 2> "$out/stderr"
rc=$?
check "runs and exits 0 (got $rc)" "[ $rc -eq 0 ]"
check "writes the JSON" "/usr/bin/python3 -c \"import json,sys; d=json.load(open('$out/a.json')); sys.exit(0 if d['strands']==5 and d['particles']==80 and d['strands_skipped']==0 and d['finite'] else 1)\""
check "writes frames" "[ -f $out/frames/frame_00012.hair ]"
# A groom file with strands that cannot be simulated: they are skipped, counted in the JSON and
# named in one warning; the others run with the default parameters.
/usr/bin/python3 - "$out/mixed.hair" <<'PY'
import math, struct, sys
strands = []
for k in range(3):  # 10 cm, 6 points, from the top of the head outwards
    a = 2 * math.pi * k / 3
    strands.append([(0.1 * i / 5 * math.cos(a), 0.1 * i / 5 * math.sin(a), 0.111) for i in range(6)])
strands.insert(1, [(0, 0, 0.111), (0, 0, 0.2)])                                 # strand 1: 2 points
strands.append([(0, 0, 0.111), (0.01, 0, 0.111), (float("nan"), 0, 0.1), (0.03, 0, 0.1)])  # 4: NaN
points = [c for s in strands for p in s for c in p]
header = b"HAIR" + struct.pack("<IIII", len(strands), len(points) // 3, 0b11, 0)
header += struct.pack("<5f", 1, 0, 1, 1, 1) + bytes(88)
body = struct.pack("<%dH" % len(strands), *[len(s) - 1 for s in strands])
open(sys.argv[1], "wb").write(header + body + struct.pack("<%df" % len(points), *points))
PY
"$run" --seconds 0.05 --set "groom_file.file=$out/mixed.hair" --json "$out/mixed.json" \
  > /dev/null 2> "$out/mixed.err"
rc=$?
check "a groom with bad strands runs and exits 0 (got $rc)" "[ $rc -eq 0 ]"
check "the JSON counts simulated and skipped strands" "/usr/bin/python3 -c \"import json,sys; d=json.load(open('$out/mixed.json')); sys.exit(0 if d['strands']==3 and d['strands_skipped']==2 and d['particles']==18 else 1)\""
check "one warning names the skipped strands" "[ \$(grep -c 'skipped 2 of 5 strands' $out/mixed.err) -eq 1 ] && grep -q 'strand 1 (2 points), strand 4 (non-finite point 2 in the file)' $out/mixed.err"
# The measurement flags: what ran is listed; the opt-in tangle series and sampling.
"$run" --seconds 0.1 --strands 6 --particles 8 --no-measure --no-tangles --no-clump-distance \
  --json "$out/m.json" > /dev/null 2>&1
check "--no-measure --no-tangles --no-clump-distance list only what still runs" "/usr/bin/python3 -c \"import json,sys; d=json.load(open('$out/m.json')); sys.exit(0 if d['measurements']==['rigid_motion','curl_shape'] and d['energy']==[] else 1)\""
"$run" --seconds 0.1 --strands 6 --particles 8 --tangle-series 2 --sample-strands 3 \
  --json "$out/t.json" > /dev/null 2>&1
check "--tangle-series and --sample-strands run and say so" "/usr/bin/python3 -c \"import json,sys; d=json.load(open('$out/t.json')); sys.exit(0 if 'tangle_series' in d['measurements'] and d['sample_stride']==2 and d['sampled_strands']==3 and set(d['measurement_s'])==set(d['measurements']) else 1)\""
for args in "--motion wobble" "--seconds abc" "--strands 0" "--set solver.nope=1" "--scene /no/such.yaml" "--bogus" "--tangle-series 0" "--sample-strands -1" "--series-stride 0"; do
  "$run" $args > /dev/null 2> "$out/err"
  rc=$?
  check "'$args' exits 2 (got $rc)" "[ $rc -eq 2 ]"
  check "'$args' says why" "[ -s $out/err ]"
done
# Water: repeatable --water-source and --dryer join the scene; the JSON carries the totals; a bad
# spec exits 2 naming the flag and the field.
"$run" --seconds 0.2 --strands 5 --particles 16 --motion still \
  --water-source shower:x=0,y=0,z=0.5,r=0.3,rate_kg_s=0.02,stop_s=0.1 \
  --water-source bath:z=-0.3 --dryer box:x=0,y=0,z=0,hx=0.5,hy=0.5,hz=0.5,start_s=0.1 \
  --json "$out/w.json" > /dev/null 2>&1
check "--water-source and --dryer run and the water balances" "/usr/bin/python3 -c \"import json,sys; d=json.load(open('$out/w.json')); b=d['water_added_kg']-d['water_removed_kg']-d['water_held_kg']-d['water_dripped_kg']-d['water_evaporated_kg']; sys.exit(0 if d['water'] and d['water_added_kg']>0.002 and d['water_evaporated_kg']>0 and abs(b)<1e-9 and len(d['mean_saturation'])==len(d['time_s']) else 1)\""
"$run" --print-scene --water-source bath:z=-0.3 --dryer box:hx=0.2 > "$out/water.yaml"
check "print-scene lists the water sources and dryers" "grep -q 'bath:z=-0.3' $out/water.yaml && grep -q 'box:x=0,y=0,z=0,hx=0.2' $out/water.yaml"
for args in "--water-source shower:r=0" "--dryer box:hx=1,fan=2" "--water-source hose:x=1"; do
  "$run" $args > /dev/null 2> "$out/err"
  rc=$?
  check "'$args' exits 2 (got $rc)" "[ $rc -eq 2 ]"
  field=$(echo "$args" | sed -E 's/^--([a-z-]+) ([a-z]+):.*/\1/')
  check "'$args' names the flag" "grep -q -- '--$field' $out/err"
done
check "a bad shower names its field" "\"$run\" --water-source shower:r=0 2>&1 | grep -q 'shower.r:'"
# Hair contact: --hair-contact on|off sets the scene key; the JSON carries the crossings (measured
# with contact on) and the contacts; anything but on/off exits 2 naming the flag.
"$run" --print-scene --hair-contact on > "$out/contact.yaml"
check "--hair-contact on sets solver.hair_contact.enabled" "grep -A1 'hair_contact:' $out/contact.yaml | grep -q 'enabled: true'"
"$run" --seconds 0.1 --strands 6 --particles 16 --motion nod --hair-contact on \
  --json "$out/c.json" > /dev/null 2>&1
check "--hair-contact on measures crossings" "/usr/bin/python3 -c \"import json,sys; d=json.load(open('$out/c.json')); sys.exit(0 if d['crossings']>=0 and len(d['crossings_series'])==6 and 'hair_contact' in d['stages'] else 1)\""
"$run" --seconds 0.1 --strands 6 --particles 16 --json "$out/c0.json" > /dev/null 2>&1
check "contact off: crossings not measured (-1)" "/usr/bin/python3 -c \"import json,sys; d=json.load(open('$out/c0.json')); sys.exit(0 if d['crossings']==-1 else 1)\""
"$run" --hair-contact yes > /dev/null 2> "$out/err"
rc=$?
check "'--hair-contact yes' exits 2 naming the flag (got $rc)" "[ $rc -eq 2 ] && grep -q -- '--hair-contact' $out/err"
"$run" --print-scene --curl-radius 0 > "$out/scene.yaml"
check "print-scene applies overrides" "grep -q 'curl_radius_m: 0 ' $out/scene.yaml"
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
