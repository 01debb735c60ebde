#!/usr/bin/env bash
# Runs clang-tidy (Debian's, version 14) with the repository's .clang-tidy over the product's
# sources (planner, scenes, server, client, tools, common, deploy; not tests or benchmarks),
# using the compile commands of the build directory; fails on any finding. All of them take
# about 45 CPU-minutes (each source parses gRPC, PCL or CLI11 again).
#
#   scripts/check-tidy.sh              every product source
#   scripts/check-tidy.sh --since REV  only the sources that changed since commit REV, or that
#                                      include a header that did (the build's dependency
#                                      records say which); everything when .clang-tidy
#                                      changed or REV is not an ancestor.
#
# The test command runs it --since the commit in .ci/tidy-base, the last one whose whole tree
# passed: record a newer one there after a full run passes (`git rev-parse HEAD`).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${STRATA_BUILD_DIR:-$root/build}
cd "$root"
mapfile -t files < <(git ls-files '*.cpp' | grep -E '^(planner|scenes|server|client|tools|common|deploy)/')

if [ "${1:-}" = --since ]; then
  base=${2:?--since needs a commit}
  if ! git merge-base --is-ancestor "$base" HEAD 2>/dev/null; then
    echo "check-tidy: $base is not an ancestor of HEAD; checking every source" >&2
  else
    mapfile -t changed < <(git diff --name-only "$base" -- .; git ls-files --others --exclude-standard)
    if printf '%s\n' "${changed[@]}" | grep -qx '.clang-tidy'; then
      echo "check-tidy: .clang-tidy changed since $base; checking every source" >&2
    else
      # Each object's dependencies from ninja (an object line, then one indented path per
      # line); the product source among them is the one the object is built from.
      mapfile -t files < <(
        { printf 'changed %s\n' "${changed[@]/#/$root/}"
          printf 'product %s\n' "${files[@]/#/$root/}"
          ninja -C "$build_dir" -t deps | awk '/^[^ ].*: #deps/ {obj = $1; next} NF {print "dep", obj, $1}'
        } | awk -v root="$root/" '
          $1 == "changed" {changed[$2] = 1; next}
          $1 == "product" {product[$2] = 1; next}
          $3 in changed {hit[$2] = 1}
          $3 in product {source[$2] = $3}
          END {
            for (obj in hit) if (obj in source) print substr(source[obj], length(root) + 1)
            for (p in product) if (p in changed) print substr(p, length(root) + 1)
          }' | sort -u)
      echo "check-tidy: ${#files[@]} sources changed since $base or include a header that did" >&2
    fi
  fi
fi
if [ "${#files[@]}" -eq 0 ]; then exit 0; fi
run-clang-tidy -p "$build_dir" -j "$(nproc)" -quiet "${files[@]}" > "$build_dir/clang-tidy.log" 2>&1 || {
  grep -E '(error|warning): ' "$build_dir/clang-tidy.log" | sed 's/\x1b\[[0-9;]*m//g' | sort -u >&2
  echo "check-tidy: clang-tidy found the problems above (full log: $build_dir/clang-tidy.log)" >&2
  exit 1
}
