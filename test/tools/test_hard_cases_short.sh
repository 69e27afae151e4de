#!/usr/bin/env bash
# Short form of the hard-case stability suite (bench/hard_cases.py --short): 4 scenes of
# config/hard/ x {explicit, backward_euler} x {1/1000 s, 1/60 s}. Asserts that every setting
# expected stable (the implicit method at both steps, explicit at 1/1000 s) passes every criterion
# (finite, strain, contact, energy, repairs); explicit at 1/60 s is run and reported, not asserted.
# Long form and criteria: README "Stability on hard cases".
set -u
build=$1
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
/usr/bin/python3 "$here/bench/hard_cases.py" --build "$build" --short --out "$out"
rc=$?
cat "$out/hard_cases_short.md"
/usr/bin/python3 - "$out/hard_cases_short.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
exp = [r for r in rows if r["expected_stable"] == "True"]
bad = [r for r in exp if r["status"] != "stable"]
for r in bad:
    print("FAIL: %s %s %s: %s\n  reproduce: %s" % (r["scene"], r["integrator"], r["substep"], r["failed"], r["command"]))
print("%d passed, %d failed" % (len(exp) - len(bad), len(bad)))
sys.exit(1 if bad or len(exp) != 12 else 0)
PY
rc2=$?
[ "$rc" -eq 0 ] && [ "$rc2" -eq 0 ]
