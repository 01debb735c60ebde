#!/usr/bin/env bash
# Configures and builds the sanitised tree into build-sanitize/ (or $STRATA_SANITIZE_BUILD_DIR):
# clang with AddressSanitizer and UndefinedBehaviorSanitizer on everything, the tests and the
# libFuzzer targets of fuzz/ included (CMakeLists.txt's STRATA_SANITIZE), at the Release
# optimisation the product ships with. Arguments are targets (default: all).
# STRATA_SANITIZE_COVERAGE and STRATA_SANITIZE_COVERAGE_EVERYWHERE, read when the tree is
# configured, set libFuzzer's coverage instrumentation and where it goes (CMakeLists.txt;
# scripts/fuzz.sh sets a fuller one, on every source, for its own tree).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${STRATA_SANITIZE_BUILD_DIR:-$root/build-sanitize}
"$root/scripts/install-deps.sh"
if [ ! -f "$build_dir/build.ninja" ]; then
  cmake -S "$root" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DSTRATA_SANITIZE=ON \
    ${STRATA_SANITIZE_COVERAGE:+-DSTRATA_SANITIZE_COVERAGE="$STRATA_SANITIZE_COVERAGE"} \
    ${STRATA_SANITIZE_COVERAGE_EVERYWHERE:+-DSTRATA_SANITIZE_COVERAGE_EVERYWHERE="$STRATA_SANITIZE_COVERAGE_EVERYWHERE"}
fi
cmake --build "$build_dir" ${1:+--target "$@"}
