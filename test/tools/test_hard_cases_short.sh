#!/usr/bin/env bash
# Short form of the hard-case stability suite (bench/hard_cases.py --short): 4 scenes of
# config/hard/ x {explicit, backward_euler, theta} x {1/1000 s, 1/60 s}, once with every strand
# simulated and once with followers (--follow-ratio 4: one strand in 4 simulated, the rest placed
# from them; every criterion over every strand but the energy, which judges the guides). Asserts
# that every setting expected stable (the two implicit methods at both steps: 16 runs) passes every
# criterion (finite, strain, contact, energy, repairs), and that explicit, whose stability bound
# (2.3e-4 s) lies below both steps, is refused with the bound named instead of run (8 runs).
# Long form and criteria: docs/hard_cases.md.
set -u
build=$1
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
status=0
for ratio in 1 4; do
  name=hard_cases_short
  [ "$ratio" -gt 1 ] && name=hard_cases_short_followers
  echo "== follow ratio $ratio"
  /usr/bin/python3 "$here/bench/hard_cases.py" --build "$build" --short --follow-ratio "$ratio" \
    --out "$out"
  rc=$?
  cat "$out/$name.md"
  /usr/bin/python3 - "$out/$name.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
exp = [r for r in rows if r["expected_stable"] == "True"]
# 4 scenes x 3 integrators x 2 steps, 2 of the integrators asserted: a suite that silently ran
# fewer settings must not pass.
if len(rows) != 24 or len(exp) != 16:
    print("FAIL: expected 24 runs with 16 asserted, got %d with %d" % (len(rows), len(exp)))
bad = [r for r in exp if r["status"] != "stable"]
bad += [r for r in rows if r["integrator"] == "explicit" and r["status"] != "refused"]
for r in bad:
    print("FAIL: %s %s %s: %s\n  reproduce: %s" % (r["scene"], r["integrator"], r["substep"], r["failed"], r["command"]))
print("%d passed, %d failed" % (len(exp) - len(bad), len(bad)))
sys.exit(1 if bad or len(rows) != 24 or len(exp) != 16 else 0)
PY
  rc2=$?
  { [ "$rc" -eq 0 ] && [ "$rc2" -eq 0 ]; } || status=1
done
exit $status
