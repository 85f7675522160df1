#!/usr/bin/env bash
# Installs what is missing, builds (Release), runs every test. Exit status: ctest's.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)"
ctest --preset release -j "$(nproc)" "$@"
