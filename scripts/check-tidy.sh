#!/usr/bin/env bash
# Runs clang-tidy (Debian's, version 14) with the repository's .clang-tidy over the product's
# sources (planner, scenes, server, client, tools, common, deploy; not tests or benchmarks),
# using the compile commands of the build directory; fails on any finding. 8-9 minutes
# on two cores.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${STRATA_BUILD_DIR:-$root/build}
cd "$root"
mapfile -t files < <(git ls-files '*.cpp' | grep -E '^(planner|scenes|server|client|tools|common|deploy)/')
run-clang-tidy -p "$build_dir" -j "$(nproc)" -quiet "${files[@]}" > "$build_dir/clang-tidy.log" 2>&1 || {
  grep -E '(error|warning): ' "$build_dir/clang-tidy.log" | sed 's/\x1b\[[0-9;]*m//g' | sort -u >&2
  echo "check-tidy: clang-tidy found the problems above (full log: $build_dir/clang-tidy.log)" >&2
  exit 1
}
