#!/usr/bin/env bash
# The rooms of the package: the core, io and ROS libraries and every node load neither the
# runner harness, nor the viewer, nor Cairo (the node must not pull in a renderer); the
# renderer and the runner do load theirs (so the check would see them).
set -u
build=$1
lib=$build/devel/lib
pass=0 fail=0
check() { if eval "$2"; then pass=$((pass + 1)); else echo "FAIL: $1"; fail=$((fail + 1)); fi; }
loads() {  # loads FILE PATTERN: the file's shared libraries (transitively) match PATTERN
  ldd "$1" | grep -qE "$2"
}
forbidden='libcairo|libwet_curly_hair_runner|libwet_curly_hair_viewer'
for l in core io ros; do
  f=$lib/libwet_curly_hair_$l.so
  check "libwet_curly_hair_$l.so is built" "[ -f $f ]"
  [ -f "$f" ] && check "libwet_curly_hair_$l.so loads none of $forbidden" "! loads $f '$forbidden'"
done
nodes=0
for main in "$(dirname "${BASH_SOURCE[0]}")"/../../src/nodes/*.cpp; do
  f=$lib/wet_curly_hair/$(basename "$main" .cpp)
  check "$(basename "$f") is built" "[ -x $f ]"
  [ -x "$f" ] && check "$(basename "$f") loads none of $forbidden" "! loads $f '$forbidden'"
  nodes=$((nodes + 1))
done
check "nodes found" "[ $nodes -gt 0 ]"
check "wet_curly_hair_render loads the viewer and Cairo" \
  "loads $lib/wet_curly_hair/wet_curly_hair_render libwet_curly_hair_viewer && loads $lib/wet_curly_hair/wet_curly_hair_render libcairo"
check "wet_curly_hair_run loads the runner" \
  "loads $lib/wet_curly_hair/wet_curly_hair_run libwet_curly_hair_runner"
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
