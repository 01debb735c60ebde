#!/usr/bin/env bash
# Fails when a tracked C++ file differs from what clang-format (Debian's, version 14) makes of it
# under the repository's .clang-format. Fix with:
#   git ls-files '*.cpp' '*.hpp' | xargs clang-format -i
set -euo pipefail
cd "$(dirname "$0")/.."
git ls-files -z '*.cpp' '*.hpp' | xargs -0 clang-format --dry-run --Werror
