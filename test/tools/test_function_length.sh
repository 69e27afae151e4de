#!/usr/bin/env bash
# No function in src/ or include/ is longer than 150 lines (scripts/check_function_length): a
# function reads as a list of named stages.
set -u
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
/usr/bin/python3 scripts/check_function_length --max 150 src include
