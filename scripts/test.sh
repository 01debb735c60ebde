#!/usr/bin/env bash
# Builds everything once, then runs the whole test suite in parallel with CTest.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${STRATA_BUILD_DIR:-$root/build}
"$root/scripts/build.sh"
ctest --test-dir "$build_dir" --output-on-failure -j "$(nproc)" "$@"
