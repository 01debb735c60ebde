#!/usr/bin/env bash
# Builds everything once, checks the C++ formatting (.clang-format) and clang-tidy's findings
# (.clang-tidy), and runs the whole test suite in parallel with CTest; then builds the
# gRPC-free concurrency tests a second time under ThreadSanitizer and runs them (Debian's gRPC
# and libgomp are not instrumented, so that build leaves them out). Arguments go to the first
# ctest (e.g. -R plan). STRATA_SKIP_TSAN=1 skips the second build.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${STRATA_BUILD_DIR:-$root/build}
"$root/scripts/build.sh"
"$root/scripts/check-format.sh"
"$root/scripts/check-tidy.sh"
"$root/scripts/install-test-tools.sh"
ctest --test-dir "$build_dir" --output-on-failure -j "$(nproc)" "$@"

if [ "${STRATA_SKIP_TSAN:-0}" = 1 ]; then exit 0; fi
tsan_dir=${build_dir}-tsan
if [ ! -f "$tsan_dir/build.ninja" ]; then
  cmake -S "$root" -B "$tsan_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSTRATA_TSAN=ON
fi
cmake --build "$tsan_dir"
ctest --test-dir "$tsan_dir" --output-on-failure -j "$(nproc)"  # Options: tests/tsan_defaults.cpp
