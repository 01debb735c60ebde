#!/usr/bin/env bash
# The main job on a built-in default: builds strata-server and the `strata` client, starts the
# server with the demo scene preloaded (map "demo"), waits until it is healthy, plans once
# from the ground floor to the upper deck to show it answering, then keeps serving on
# 0.0.0.0:50051 (metrics on 127.0.0.1:9090, the web viewer on http://localhost:8080/) until
# Ctrl-C. Extra arguments go to strata-server (--http-port -1 turns the viewer off).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${STRATA_BUILD_DIR:-$root/build}
"$root/scripts/build.sh" --target strata-server strata strata-health-probe

listen=${STRATA_LISTEN:-0.0.0.0:50051}
port=${listen##*:}
# The viewer through its variable, so that an --http-port among the arguments still wins.
export STRATA_HTTP_PORT=${STRATA_HTTP_PORT:-8080}
"$build_dir/server/strata-server" --listen "$listen" "$@" &
server=$!
trap 'kill -TERM "$server" 2>/dev/null; wait "$server"' INT TERM

# Health turns SERVING once the preloaded maps are ACTIVE (the demo: well under a second).
for _ in $(seq 1 120); do
  if "$build_dir/deploy/health_probe/strata-health-probe" "127.0.0.1:$port" --timeout-s 1 \
      >/dev/null 2>&1; then
    break
  fi
  kill -0 "$server" 2>/dev/null || { wait "$server"; exit 1; }
  sleep 0.5
done

echo "--- strata plan --map demo --start 2,2,0.3 --goal 10,10,3.3 (floor -> upper deck)" >&2
"$build_dir/client/strata" --server "127.0.0.1:$port" plan --map demo \
  --start 2,2,0.3 --goal 10,10,3.3 || true
echo "--- strata-server is serving on $listen (Ctrl-C stops it); see README for grpcurl" >&2
[ "$STRATA_HTTP_PORT" -ge 0 ] 2>/dev/null &&
  echo "--- web viewer: http://localhost:$STRATA_HTTP_PORT/ (unless an argument moved it)" >&2
wait "$server"
