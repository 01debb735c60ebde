#!/usr/bin/env bash
# Runs Strata's libFuzzer targets (fuzz/) for as long as asked, one after another: builds them
# if needed into build-fuzz/ (scripts/build-sanitize.sh's tree, with comparison tracing added
# to the coverage the test suite's tree has, so that mutations find magic values, and on every
# source, not only the fuzzed code's), writes the
# seed corpora, and prints each target's executions, speed and findings. A finding (crash,
# abort, leak, timeout) leaves its input in build-fuzz/fuzz/fuzz-artifacts/ and makes the
# script exit 1.
#
#   bash scripts/fuzz.sh [--seconds N | --runs N] [TARGET...]
#     TARGET: pcd ply octomap saved_model upload plan_request request (default: all)
#     default: --seconds 60 each; the corpus grows in BUILD/fuzz/corpus/TARGET between runs
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${STRATA_FUZZ_BUILD_DIR:-$root/build-fuzz}
export STRATA_SANITIZE_BUILD_DIR=$build_dir
export STRATA_SANITIZE_COVERAGE=inline-8bit-counters,indirect-calls,trace-cmp,pc-table
export STRATA_SANITIZE_COVERAGE_EVERYWHERE=ON
limit=(-max_total_time=60)
case "${1:-}" in
  --seconds) limit=(-max_total_time="$2"); shift 2 ;;
  --runs) limit=(-runs="$2"); shift 2 ;;
esac
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(pcd ply octomap saved_model upload plan_request request)

"$root/scripts/build-sanitize.sh" make_fuzz_seeds "${targets[@]/%/_fuzzer}"
fuzz_dir=$build_dir/fuzz
"$build_dir/fuzz/make_fuzz_seeds" "$fuzz_dir/seeds" >/dev/null

status=0
for target in "${targets[@]}"; do
  mkdir -p "$fuzz_dir/corpus/$target" "$fuzz_dir/fuzz-artifacts"
  log=$fuzz_dir/$target.log
  start=$(date +%s)
  if ASAN_OPTIONS=detect_leaks=1 "$fuzz_dir/${target}_fuzzer" "${limit[@]}" -timeout=10 \
      -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$fuzz_dir/fuzz-artifacts/$target-" \
      "$fuzz_dir/corpus/$target" "$fuzz_dir/seeds/$target" >"$log" 2>&1; then
    result=clean
  else
    result="FINDING (see $log and $fuzz_dir/fuzz-artifacts/)"
    status=1
  fi
  execs=$(awk '/stat::number_of_executed_units/ {print $2}' "$log")
  speed=$(awk '/stat::average_exec_per_sec/ {print $2}' "$log")
  corpus=$(find "$fuzz_dir/corpus/$target" -type f | wc -l)
  echo "$target: ${execs:-?} executions, ${speed:-?} exec/s, $(( $(date +%s) - start )) s, corpus $corpus, $result"
done
exit $status
