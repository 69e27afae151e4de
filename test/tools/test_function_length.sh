#!/usr/bin/env bash
# No function in src/ or include/ is longer than 150 lines (scripts/check_function_length),
# except in the core solver (src/core, include/wet_curly_hair/core), which is being split apart
# on its own.
set -u
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
/usr/bin/python3 scripts/check_function_length --max 150 \
  --exclude src/core --exclude include/wet_curly_hair/core src include
