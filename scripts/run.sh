#!/usr/bin/env bash
# The main job on a built-in default: builds, then assesses the built-in demo scene and prints
# its summary. Extra arguments go to `strata-offline assess`.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${STRATA_BUILD_DIR:-$root/build}
"$root/scripts/build.sh" --target strata-offline
exec "$build_dir/bench/strata-offline" assess "${@:-scene:two_level_ramp}"
