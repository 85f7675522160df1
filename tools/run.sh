#!/usr/bin/env bash
# Installs what is missing, builds (Release), then runs the project's main job.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)"
if [ -n "${DISPLAY:-}" ]; then exec build/bin/csm_flythrough "$@"; else exec build/bin/csm_flythrough --headless --frames 60 --shot-every 20 --out out "$@"; fi
