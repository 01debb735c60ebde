#!/usr/bin/env bash
# Time to SERVING of a strata-server replica with ten preloaded maps, on a fresh map store
# (the first replica assesses them and writes them to the store) and again on the store that
# now holds them (a new replica: nothing assessed). Figures for docs/benchmarks.md, "Map
# store"; not part of the test path.
#
#   bash bench/replica_startup.sh [BUILD_DIR] [SCENE]    (defaults: build, uneven_terrain)
set -euo pipefail
build=${1:-build}
scene=${2:-uneven_terrain}
server="$build/server/strata-server"
probe="$build/deploy/health_probe/strata-health-probe"
store=$(mktemp -d /tmp/strata-startup-store.XXXXXX)
port=$((20000 + RANDOM % 20000))
pid=""
trap '[ -n "$pid" ] && kill "$pid" 2>/dev/null; rm -rf "$store"' EXIT

preloads=()
for seed in $(seq 1 10); do preloads+=(--preload "m$seed=scene:$scene:$seed"); done

# Starts a replica, waits for SERVING (the probe every 20 ms), prints the seconds taken.
time_to_serving() {
  local start end
  start=$(date +%s.%N)
  "$server" --listen "127.0.0.1:$port" --metrics-port -1 --map-store "$store" \
    --log-level warning "${preloads[@]}" &
  pid=$!
  until "$probe" "127.0.0.1:$port" >/dev/null 2>&1; do
    kill -0 "$pid" 2>/dev/null || { echo "server exited" >&2; exit 1; }
    sleep 0.02
  done
  end=$(date +%s.%N)
  kill -TERM "$pid"
  wait "$pid" || true
  awk -v a="$start" -v b="$end" 'BEGIN { printf "%.2f\n", b - a }'
}

echo "ten maps (scene:$scene:1..10), $(nproc) cores, $(date -u +%F)"
echo "first replica, empty store (assesses and writes all ten): $(time_to_serving) s"
for run in 1 2 3; do
  echo "new replica, store holds them (run $run):              $(time_to_serving) s"
done
