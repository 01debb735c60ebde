#!/usr/bin/env bash
# Installs what only the tests need beyond scripts/install-deps.sh:
# - Debian's headless Chromium, its WebDriver and Python's Selenium, which drive the web viewer
#   in tests/server/viewer_browser_test.py (apt: chromium, chromium-driver, python3-selenium);
# - Buf's CLI, whose `buf curl` is the independent gRPC client that checks reflection and
#   health (BUILD-NOTES.md), from the npm registry at the version pinned in
#   tools/buf/package-lock.json (npm itself from apt when missing).
# Idempotent. Without network it warns and returns 0: the tests that need a missing tool then
# skip and say why.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
buf_dir=$root/tools/buf
sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)

apt_packages=(chromium chromium-driver python3-selenium)
[ -x "$buf_dir/node_modules/.bin/buf" ] || command -v npm >/dev/null 2>&1 || apt_packages+=(npm)
missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "install-test-tools: installing ${missing[*]}" >&2
  if ! { "${sudo_cmd[@]}" apt-get update &&
         DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y \
           --no-install-recommends "${missing[@]}"; }; then
    echo "install-test-tools: could not install ${missing[*]}; the tests that need them skip" >&2
  fi
fi

[ -x "$buf_dir/node_modules/.bin/buf" ] && exit 0
command -v npm >/dev/null 2>&1 || exit 0
# --ignore-scripts: the CLI ships in a per-platform package; its postinstall only checks that.
if ! (cd "$buf_dir" && npm install --ignore-scripts --no-audit --no-fund --loglevel=error \
    --fetch-timeout=30000 --fetch-retries=1); then
  echo "install-test-tools: could not install Buf's CLI; the buf curl test will skip" >&2
fi
