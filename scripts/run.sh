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
# The viewer through its variable, so that an --http-port among the arguments still wins; the
# port the viewer ends up on is the last --http-port given, else the variable.
export STRATA_HTTP_PORT=${STRATA_HTTP_PORT:-8080}
http_port=$STRATA_HTTP_PORT
previous=
for argument in "$@"; do
  case "$argument" in
    --http-port=*) http_port=${argument#--http-port=} ;;
    *) [ "$previous" = --http-port ] && http_port=$argument ;;
  esac
  previous=$argument
done
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

strata=("$build_dir/client/strata" --server "127.0.0.1:$port")
if "${strata[@]}" maps get demo >/dev/null 2>&1; then
  echo "--- strata plan --map demo --start 2,2,0.3 --goal 10,10,3.3 (floor -> upper deck)" >&2
  "${strata[@]}" plan --map demo --start 2,2,0.3 --goal 10,10,3.3 || true
else
  # --map-root or --preload among the arguments replaced the demo: say what is there instead.
  echo "--- no map 'demo' here (an argument replaced the demo preload), so no plan was made;" \
    "the maps loaded:" >&2
  "${strata[@]}" maps list >&2 || true
  echo "--- plan on one: ${strata[*]} plan --map ID --start X,Y,Z --goal X,Y,Z" >&2
fi
echo "--- strata-server is serving on $listen (Ctrl-C stops it); see README for grpcurl" >&2
if [ "$http_port" -ge 0 ] 2>/dev/null; then
  echo "--- web viewer: http://localhost:$http_port/" >&2
fi
wait "$server"
