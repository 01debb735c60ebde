#!/usr/bin/env bash
# Runs a benchmark that takes --etcd (shared_schedule_benchmark, store_benchmark) against a
# throwaway etcd (Debian's etcd-server) on loopback, its data in a temporary directory removed
# at the end.
#   bash bench/with_etcd.sh BUILD_DIR BENCHMARK [benchmark flags...]
#   e.g. bash bench/with_etcd.sh build store_benchmark scene:outdoor_site:size_m=400 --runs 3
set -euo pipefail
build=$1
benchmark=$2
shift 2
data=$(mktemp -d)
port=$(( 20000 + RANDOM % 20000 ))
etcd --data-dir "$data" --listen-client-urls "http://127.0.0.1:$port" \
  --advertise-client-urls "http://127.0.0.1:$port" \
  --listen-peer-urls "http://127.0.0.1:$((port + 1))" >"$data.log" 2>&1 &
etcd_pid=$!
trap 'kill $etcd_pid 2>/dev/null; wait $etcd_pid 2>/dev/null; rm -rf "$data" "$data.log"' EXIT
for _ in $(seq 100); do
  grep -q "ready to serve client requests" "$data.log" && break
  sleep 0.1
done
"$build/bench/$benchmark" --etcd "127.0.0.1:$port" "$@"
