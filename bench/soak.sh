#!/usr/bin/env bash
# Load and soak: N clients for S seconds against a real strata-server hosting the spiral and
# scene20.2 (server_benchmark --mix spiral plans on the spiral), the server's resident memory and threads read from /proc
# every 15 s; then, optionally, SIGTERM while the load runs, counting the calls the server had
# started that did not finish well. Figures for docs/benchmarks.md ("Hostile input"); not part
# of the test path. Needs ../shared/maps.
#
#   bash bench/soak.sh [BUILD_DIR] [CLIENTS] [SECONDS] [--sigterm-after S] [-- SERVER_FLAGS...]
#
# Extra environment for the server goes through the environment (e.g. MALLOC_ARENA_MAX=2).
set -euo pipefail
build=${1:-build}
clients=${2:-64}
seconds=${3:-180}
shift $(($# < 3 ? $# : 3))
sigterm_after=""
if [ "${1:-}" = "--sigterm-after" ]; then
  sigterm_after=$2
  shift 2
fi
[ "${1:-}" = "--" ] && shift
root=$(cd "$(dirname "$0")/.." && pwd)
maps=$root/../shared/maps
port=$((20000 + RANDOM % 20000))
log=$(mktemp /tmp/strata-soak-log.XXXXXX)
pid=""
sampler=""
trap '[ -n "$sampler" ] && kill "$sampler" 2>/dev/null; [ -n "$pid" ] && kill "$pid" 2>/dev/null; rm -f "$log"' EXIT

"$build/server/strata-server" --map-root "$maps" \
  --preload spiral=spiral0.3_2.pcd,resolution_m=0.2 --preload s20=scene20.2.pcd,resolution_m=0.2 \
  --listen "127.0.0.1:$port" \
  --metrics-port -1 "$@" 2>"$log" &
pid=$!
until "$build/deploy/health_probe/strata-health-probe" "127.0.0.1:$port" >/dev/null 2>&1; do
  kill -0 "$pid" 2>/dev/null || { cat "$log" >&2; exit 1; }
  sleep 0.1
done

# RSS [MiB] and threads every 15 s, from the start of the load.
(
  t=0
  while kill -0 "$pid" 2>/dev/null; do
    rss=$(awk '/^VmRSS/ {print int($2 / 1024)}' "/proc/$pid/status" 2>/dev/null || true)
    threads=$(awk '/^Threads/ {print $2}' "/proc/$pid/status" 2>/dev/null || true)
    [ -n "$rss" ] && echo "rss t=${t}s ${rss} MiB threads=${threads}" >&2
    sleep 15
    t=$((t + 15))
  done
) &
sampler=$!

if [ -n "$sigterm_after" ]; then
  ( sleep "$sigterm_after"; kill -TERM "$pid" ) &
fi
"$build/bench/server_benchmark" --server "127.0.0.1:$port" --runs 1 --seconds "$seconds" \
  --clients "$clients" --mix spiral --deadline-s 10 || true

if [ -n "$sigterm_after" ]; then
  wait "$pid" || true
  pid=""
  # Every call the server started is logged when it ends, with its code.
  after=$(sed -n '/event=shutdown/,$p' "$log")
  echo "--- calls that ended after SIGTERM: $(grep -c "event=rpc rpc=Plan" <<<"$after" || true)" \
    "Plan calls, of which failed:"
  grep -E "event=rpc rpc=Plan" <<<"$after" | grep -v "code=OK" | sed 's/^/  /' || echo "  none"
  grep -E "event=(shutdown|stopped)" "$log" | sed 's/^/  /'
fi
