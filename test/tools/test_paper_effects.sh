#!/usr/bin/env bash
# Short form of the paper's comparisons: asserts the direction of each effect (wet tips curl
# tighter, wet hair clumps, wet strands stay on the sphere longer, ...). Long form: docs/paper.md.
exec /usr/bin/python3 "$(dirname "${BASH_SOURCE[0]}")/../../bench/reproduce_paper.py" "$1" --short
