#!/usr/bin/env bash
# Builds everything once with clang, AddressSanitizer and UndefinedBehaviorSanitizer
# (scripts/build-sanitize.sh), checks the C++ formatting (.clang-format) and clang-tidy's
# findings (.clang-tidy; beside the tests), and runs the whole test suite there in parallel
# with CTest: a memory error, a leak or undefined behaviour fails the test that meets it. The
# suite includes a 10-second smoke run of each libFuzzer target (fuzz/, label "fuzz"). Then
# the gRPC-free concurrency tests are built a second time under ThreadSanitizer and run
# (Debian's gRPC is not instrumented, so that build leaves it out).
#
# One full build, not a plain Release one beside the sanitised one: CI has two cores and 30
# minutes, and the sanitised build runs every test the plain one would, with more checks.
# `scripts/build.sh` then `ctest --test-dir build` runs the suite on the plain build.
#
# Arguments go to the first ctest (e.g. -R plan). STRATA_SKIP_FUZZ=1 leaves the fuzzers' smoke
# runs out, STRATA_SKIP_TSAN=1 the ThreadSanitizer build.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${STRATA_SANITIZE_BUILD_DIR:-$root/build-sanitize}
# Each stage says how long it took, so a slow CI run shows where its time went.
stage_start=$SECONDS
stage_done() { echo "test.sh: $1 took $((SECONDS - stage_start)) s (total $SECONDS s)"; stage_start=$SECONDS; }
"$root/scripts/build-sanitize.sh"
stage_done "the sanitised build"
"$root/scripts/check-format.sh"
"$root/scripts/install-test-tools.sh"
# clang-tidy checks the product sources that changed since the last commit whose whole tree
# passed it (.ci/tidy-base; scripts/check-tidy.sh says how to move it), since a full run takes
# about 45 CPU-minutes. It runs beside the test suite at the lowest priority, in the time the
# suite's server and process tests leave the cores idle; the tests keep the CPU whenever they
# want it.
(STRATA_BUILD_DIR=$build_dir nice -n 19 "$root/scripts/check-tidy.sh" --since "$(cat "$root/.ci/tidy-base")"
 echo "test.sh: clang-tidy finished at total $SECONDS s") &
tidy=$!
trap 'kill $tidy 2>/dev/null || true' EXIT
# libomp, the sanitised tree's OpenMP, registers each process that loads it in
# /dev/shm/__KMP_REGISTERED_LIB_<pid>_<uid> and removes the file at exit. A process killed while
# it registers (the tests kill map workers and servers) leaves the file empty, and any later
# process given that pid aborts as it starts ("OMP: Error #15: ... found unknown library
# already initialized"): on a machine that runs the suite again and again, a test failed so.
# The files of processes no longer running are removed before the suite.
for registration in /dev/shm/__KMP_REGISTERED_LIB_*_"$(id -u)"; do
  pid=${registration#/dev/shm/__KMP_REGISTERED_LIB_}
  pid=${pid%_*}
  [ ! -e "$registration" ] || [ -d "/proc/$pid" ] || rm -f "$registration"
done
skip_fuzz=()
[ "${STRATA_SKIP_FUZZ:-0}" != 1 ] || skip_fuzz=(-LE fuzz)
# Sanitiser settings: tests/sanitize_defaults.cpp, server/map_worker_sanitizers.cpp.
ctest --test-dir "$build_dir" --output-on-failure -j "$(nproc)" "${skip_fuzz[@]}" "$@"
stage_done "the sanitised suite"
wait $tidy
trap - EXIT
stage_done "waiting for clang-tidy"

if [ "${STRATA_SKIP_TSAN:-0}" = 1 ]; then exit 0; fi
tsan_dir=${build_dir%-sanitize}-tsan
if [ ! -f "$tsan_dir/build.ninja" ]; then
  cmake -S "$root" -B "$tsan_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DSTRATA_TSAN=ON
fi
cmake --build "$tsan_dir"
stage_done "the ThreadSanitizer build"
ctest --test-dir "$tsan_dir" --output-on-failure -j "$(nproc)"  # Options: tests/tsan_defaults.cpp
stage_done "the ThreadSanitizer suite"
