#!/usr/bin/env bash
# Every ctest test of the build has a label (unit, integration, ros or slow) and a timeout, so that
# scripts/test --quick can select by label and no test can hang CI (CMakeLists.txt sets them).
set -u
build=$1
cd "$build" || { echo "FAIL: no build directory '$build'"; echo "0 passed, 1 failed"; exit 1; }
ctest --show-only=json-v1 > tests.json.tmp 2> /dev/null
/usr/bin/python3 - tests.json.tmp <<'PY'
import json, sys
tests = json.load(open(sys.argv[1]))["tests"]
known = {"unit", "integration", "ros", "slow"}
bad = []
for t in tests:
    props = {p["name"]: p["value"] for p in t.get("properties", [])}
    labels = props.get("LABELS", [])
    if not labels or not set(labels) <= known:
        bad.append("%s: labels %s" % (t["name"], labels))
    if not props.get("TIMEOUT", 0) > 0:
        bad.append("%s: no TIMEOUT" % t["name"])
# Fewer tests than the package has means the listing went wrong, not that all is well.
if len(tests) < 30:
    bad.append("only %d tests listed" % len(tests))
for b in bad:
    print("FAIL: " + b)
print("%d passed, %d failed" % (len(tests) - len(bad), len(bad)))
sys.exit(1 if bad else 0)
PY
rc=$?
rm -f tests.json.tmp
exit $rc
