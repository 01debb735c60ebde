#!/usr/bin/env bash
# Installs what bench/plots/plot_bench.py needs (Debian's python3-matplotlib and python3-numpy,
# used with /usr/bin/python3). Not part of the build or the tests. Idempotent: returns at once
# when both are installed.
set -euo pipefail

packages=(python3-matplotlib python3-numpy)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "install-plot-deps: installing ${missing[*]}" >&2
sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
"${sudo_cmd[@]}" apt-get update
DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y --no-install-recommends "${missing[@]}"
