#!/usr/bin/env bash
# bench/node_10k.sh end to end on a small groom: with --sink, wet_curly_hair_strands_sink takes
# the node's ~strands as raw bytes and the probe counts what it took (the size of every frame);
# with --sink --nodelet the node and the sink run as nodelets of one manager;
# with --status-only nothing takes them, and the node builds none. The timings themselves are the
# bench's, not checked here.
set -u
build=$1
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
tool_path wet_curly_hair_strands_sink "$build" > /dev/null || exit 1
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
pass=0 fail=0
check() { if eval "$2"; then pass=$((pass + 1)); else echo "FAIL: $1"; fail=$((fail + 1)); fi; }
field() { /usr/bin/python3 -c "import json; print(json.load(open('$1'))['$2'])"; }

WCH_BUILD=$build bench/node_10k.sh --strands 60 --follow-ratio 4 --seconds 2 --sink \
  --out "$out/sink" > "$out/sink.txt" 2>&1
rc=$?
check "node_10k.sh --sink runs (got $rc)" "[ $rc -eq 0 ]"
json=$out/sink/node_10k.json
# 60 strands x 32: positions, saturation and display positions as float32, 23,040 bytes.
check "the sink took the frames" \
  "[ \"\$(field $json consumer)\" = sink ] && /usr/bin/python3 -c \"import json,sys; d=json.load(open('$json')); sys.exit(0 if d['messages_received_per_s'] > 10 and d['message_bytes'] > 23040 else 1)\""
# The head pose lookups are timed: their mean per frame, the bounded wait for the pose included,
# is at least 0 and at most the node's default ~tf_timeout_s (0.05 s) plus a lookup.
check "the pose lookups' time per frame is reported" \
  "/usr/bin/python3 -c \"import json,sys; t=json.load(open('$json'))['tf_lookup_time_s']; sys.exit(0 if 0.0 <= t < 0.06 else 1)\""
# Every figure names its CPU: the runner's own words for it, family and model included.
check "the figures name the CPU" "field $json cpu | grep -q 'family [0-9]*, model [0-9]*'"
# --nodelet: the node and the sink as nodelets of one manager; the sink takes the frames in process.
WCH_BUILD=$build bench/node_10k.sh --strands 60 --follow-ratio 4 --seconds 2 --sink --nodelet \
  --out "$out/nodelet" > "$out/nodelet.txt" 2>&1
rc=$?
json=$out/nodelet/node_10k.json
check "node_10k.sh --sink --nodelet runs (got $rc)" "[ $rc -eq 0 ]"
check "the sink nodelet took the node nodelet's frames, of the same size as over TCPROS" \
  "[ \"\$(field $json consumer)\" = 'sink nodelet' ] && [ \"\$(field $json node)\" = nodelet ] && [ \"\$(field $json message_bytes)\" = \"\$(field $out/sink/node_10k.json message_bytes)\" ] && /usr/bin/python3 -c \"import json,sys; sys.exit(0 if json.load(open('$json'))['messages_received_per_s'] > 10 else 1)\""
WCH_BUILD=$build bench/node_10k.sh --strands 60 --follow-ratio 4 --seconds 2 --status-only \
  --out "$out/none" > "$out/none.txt" 2>&1
rc=$?
json=$out/none/node_10k.json
check "node_10k.sh --status-only runs, and nothing takes the frames (got $rc)" \
  "[ $rc -eq 0 ] && [ \"\$(field $json consumer)\" = none ] && [ \"\$(field $json message_bytes)\" = 0 ]"
# A frame nobody takes is not built: no conversion time without a subscriber, some with one.
check "the node builds ~strands only for a subscriber" \
  "[ \"\$(field $json conversion_time_s)\" = 0.0 ] && /usr/bin/python3 -c \"import json,sys; sys.exit(0 if json.load(open('$out/sink/node_10k.json'))['conversion_time_s'] > 0 else 1)\""
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
