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
check "writes the JSON" "/usr/bin/python3 -c \"import json,sys; d=json.load(open('$out/a.json')); sys.exit(0 if d['strands']==5 and d['particles']==80 and d['finite'] else 1)\""
check "writes frames" "[ -f $out/frames/frame_00012.hair ]"
for args in "--motion wobble" "--seconds abc" "--strands 0" "--set solver.nope=1" "--scene /no/such.yaml" "--bogus"; do
  "$run" $args > /dev/null 2> "$out/err"
  rc=$?
  check "'$args' exits 2 (got $rc)" "[ $rc -eq 2 ]"
  check "'$args' says why" "[ -s $out/err ]"
done
"$run" --print-scene --curl-radius 0 > "$out/scene.yaml"
check "print-scene applies overrides" "grep -q 'curl_radius_m: 0 ' $out/scene.yaml"
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
