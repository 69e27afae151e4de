#!/usr/bin/env bash
# Two runs of the offline runner with the same inputs and thread count write bit-identical frames
# (--hair-frames, compared byte for byte), with 1 and with 2 threads; and, as the solver promises
# (IntegratorConfig::threads), 1 and 2 threads give the same frames too.
set -u
build=$1
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
run=$(tool_path wet_curly_hair_run "$build") || exit 1
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
pass=0 fail=0
check() { if eval "$2"; then pass=$((pass + 1)); else echo "FAIL: $1"; fail=$((fail + 1)); fi; }
same() {  # same DIR_A DIR_B: same file names, every file byte for byte equal
  [ "$(ls "$1")" = "$(ls "$2")" ] || return 1
  for f in "$1"/*.hair; do cmp -s "$f" "$2/$(basename "$f")" || { echo "  differs: $(basename "$f")"; return 1; }; done
}
args=(--strands 12 --particles 24 --seconds 0.5 --motion spin:rate_hz=2,stop_s=0.25
      --saturation 0,1 --obstacle sphere:x=0.15,y=0,z=0.1,r=0.05 --integrator theta --substep 0.001
      --saturation-at 0.3,1,1 --hair-stride 3)
for threads in 1 2; do
  for k in a b; do
    "$run" "${args[@]}" --threads $threads --hair-frames "$out/t${threads}$k" > /dev/null 2> "$out/err"
    rc=$?
    check "runs with $threads thread(s) ($k) (got $rc)" "[ $rc -eq 0 ]"
  done
  check "frames written ($threads threads)" "[ \$(ls $out/t${threads}a | wc -l) -eq 11 ]"
  check "two runs with $threads thread(s) are bit-identical" "same $out/t${threads}a $out/t${threads}b"
done
check "1 and 2 threads are bit-identical" "same $out/t1a $out/t2a"
# The explicit integrator too.
for k in a b; do
  "$run" "${args[@]}" --integrator explicit --substep 0.0002 --threads 2 --hair-frames "$out/e$k" > /dev/null 2>&1
done
check "explicit, 2 threads: two runs bit-identical" "same $out/ea $out/eb"
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
