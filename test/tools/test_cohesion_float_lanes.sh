#!/usr/bin/env bash
# The build's choice of the lattice cohesion's float lanes (cmake/cohesion_float_lanes.cmake), on
# CPUs this machine is not: /proc/cpuinfo excerpts of a Zen 4 (family 25, 8 lanes), a Zen 5
# (family 26) and an Intel Xeon (left to the header: 16 with AVX-512), a portable build (not
# native: left to the flags), the settings 8 and 16 as given, and a bad setting refused by name.
# Any argument is ignored (ctest passes the build folder).
set -u
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
source "$here/test/tools/lib.sh"
require_command cmake cmake
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
pass=0 fail=0
check() { if eval "$2"; then pass=$((pass + 1)); else echo "FAIL: $1"; fail=$((fail + 1)); fi; }
printf 'processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 25\nmodel\t\t: 17\n' > "$tmp/zen4"
printf 'processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 26\nmodel\t\t: 2\n' > "$tmp/zen5"
printf 'processor\t: 0\nvendor_id\t: GenuineIntel\ncpu family\t: 6\nmodel\t\t: 143\n' > "$tmp/xeon"
# Prints the lanes chosen for a setting, native flag and cpuinfo file ("-" where left to the header).
lanes() {
  cat > "$tmp/probe.cmake" <<CMAKE
include("$here/cmake/cohesion_float_lanes.cmake")
wch_cohesion_float_lanes("$1" "$2" "$3" chosen)
if(chosen)
  message(STATUS "lanes=\${chosen}")
else()
  message(STATUS "lanes=-")
endif()
CMAKE
  cmake -P "$tmp/probe.cmake" 2>&1 | sed -n 's/^-- lanes=//p'
}
check "auto on Zen 4 (AMD family 25) gives 8" "[ \"\$(lanes auto ON $tmp/zen4)\" = 8 ]"
check "auto on Zen 5 (AMD family 26) is left to the header" "[ \"\$(lanes auto ON $tmp/zen5)\" = - ]"
check "auto on an Intel Xeon is left to the header" "[ \"\$(lanes auto ON $tmp/xeon)\" = - ]"
check "auto in a portable build reads no CPU" "[ \"\$(lanes auto OFF $tmp/zen4)\" = - ]"
check "8 and 16 are taken as given" \
  "[ \"\$(lanes 8 ON $tmp/zen5)\" = 8 ] && [ \"\$(lanes 16 ON $tmp/zen4)\" = 16 ]"
cat > "$tmp/bad.cmake" <<CMAKE
include("$here/cmake/cohesion_float_lanes.cmake")
wch_cohesion_float_lanes("12" ON "$tmp/zen5" chosen)
CMAKE
cmake -P "$tmp/bad.cmake" > "$tmp/bad.log" 2>&1
bad_rc=$?
check "12 is refused, naming the setting (got $bad_rc)" \
  "[ $bad_rc -ne 0 ] && grep -q \"WCH_COHESION_FLOAT_LANES must be auto, 8 or 16, not '12'\" $tmp/bad.log"
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
