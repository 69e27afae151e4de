# Sourced by the test_*.sh scripts: finding what they run. A missing tool or data file fails the
# test with its name (scripts/test installs and builds everything the tests need): a test that
# cannot run has not passed.

# tool_path NAME BUILD: the built executable NAME under BUILD, or exit 1 saying it is missing.
tool_path() {
  local p
  p=$(find "$2" -name "$1" -type f -perm -u+x 2> /dev/null | head -1)
  if [ -z "$p" ]; then
    # stderr: the caller captures stdout as the path.
    echo "FAIL: $1 not found under '$2' (build it: scripts/test builds every tool)" >&2
    echo "0 passed, 1 failed" >&2
    exit 1
  fi
  echo "$p"
}

# require_command NAME PACKAGE: exit 1 unless NAME is on PATH.
require_command() {
  if ! command -v "$1" > /dev/null; then
    echo "FAIL: $1 is not installed (apt-get install $2; scripts/test installs it)"
    echo "0 passed, 1 failed"
    exit 1
  fi
}
