#!/usr/bin/env bash
# Runs bench/store_benchmark with the maps' heads on a throwaway etcd (Debian's etcd-server) on
# loopback, its data in a temporary directory removed at the end: the second replica learns
# of each edit through its etcd watch, as strata-server replicas started with --etcd do.
#   bash bench/store_etcd.sh [BUILD_DIR] MAP [benchmark flags...]
set -euo pipefail
build=${1:-build}
shift || true
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
"$build/bench/store_benchmark" --etcd "127.0.0.1:$port" "$@"
