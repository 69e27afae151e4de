#!/usr/bin/env bash
# .clang-format keeps one style: every C++ source and header of the package must be formatted
# (clang-format --dry-run -Werror). Fails listing the files that are not, and fails when
# clang-format itself is missing (scripts/test installs it).
set -u
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
if ! command -v clang-format > /dev/null; then
  echo "clang-format is not installed (scripts/test installs Debian's clang-format)"
  echo "0 passed, 1 failed"
  exit 1
fi
mapfile -t files < <(git ls-files '*.cpp' '*.h' '*.inc' 2>/dev/null || find src include test bench fuzz -name '*.cpp' -o -name '*.h')
if [ ${#files[@]} -eq 0 ]; then
  echo "no C++ files found"
  echo "0 passed, 1 failed"
  exit 1
fi
bad=()
for f in "${files[@]}"; do
  clang-format --dry-run -Werror --style=file "$f" > /dev/null 2>&1 || bad+=("$f")
done
if [ ${#bad[@]} -gt 0 ]; then
  echo "not formatted with .clang-format (run: clang-format -i FILE):"
  printf '  %s\n' "${bad[@]}"
  echo "$(( ${#files[@]} - ${#bad[@]} )) passed, ${#bad[@]} failed"
  exit 1
fi
echo "${#files[@]} passed, 0 failed"
