#!/usr/bin/env bash
# A short fuzz run of the three parsers (scripts/fuzz, 20 s per target, ASan + UBSan): builds the
# libFuzzer targets into _build_fuzz/ and fails if any target finds a crash, leak, timeout or
# out-of-memory input (saved to fuzz/regressions/<target>/). $1 (the normal build) is not used.
# Fails, saying what is missing, when clang++ or its libFuzzer runtime is not installed
# (scripts/setup_common.sh installs both: clang, libclang-rt-14-dev): a fuzz run that could not
# run has not passed.
set -u
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cxx=""
for c in clang++ clang++-14; do
  if command -v "$c" > /dev/null; then cxx=$(command -v "$c"); break; fi
done
if [ -z "$cxx" ]; then
  echo "FAIL: clang++ is not installed (apt-get install clang libclang-rt-14-dev)"
  echo "0 passed, 1 failed"
  exit 1
fi
rt=$("$cxx" -print-runtime-dir 2> /dev/null || true)
if [ ! -f "$rt/libclang_rt.fuzzer-x86_64.a" ] && [ ! -f "$rt/libclang_rt.fuzzer.a" ]; then
  echo "FAIL: $cxx has no libFuzzer runtime in '$rt' (apt-get install libclang-rt-14-dev)"
  echo "0 passed, 1 failed"
  exit 1
fi
seconds=${WCH_FUZZ_SHORT_SECONDS:-20}
start=$(date +%s)
WCH_FUZZ_JOBS=${WCH_FUZZ_JOBS:-$(nproc)} "$root/scripts/fuzz" "$seconds"
rc=$?
echo "build + run: $(( $(date +%s) - start )) s"
if [ "$rc" -eq 0 ]; then echo "1 passed, 0 failed"; else echo "0 passed, 1 failed"; fi
exit "$rc"
