#!/usr/bin/env bash
# Installs what only the tests need beyond scripts/install-deps.sh: Buf's CLI, whose `buf curl`
# is the independent gRPC client that checks reflection and health (BUILD-NOTES.md). It comes
# from the npm registry at the version pinned in tools/buf/package-lock.json (npm itself from
# apt when missing). Idempotent. Without network it warns and returns 0: the reflection test
# then skips and says why.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
buf_dir=$root/tools/buf
[ -x "$buf_dir/node_modules/.bin/buf" ] && exit 0

if ! command -v npm >/dev/null 2>&1; then
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y --no-install-recommends npm
fi
# --ignore-scripts: the CLI ships in a per-platform package; its postinstall only checks that.
if ! (cd "$buf_dir" && npm install --ignore-scripts --no-audit --no-fund --loglevel=error \
    --fetch-timeout=30000 --fetch-retries=1); then
  echo "install-test-tools: could not install Buf's CLI; the buf curl test will skip" >&2
fi
