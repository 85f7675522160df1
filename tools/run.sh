#!/usr/bin/env bash
# Installs what is missing, builds (Release), then runs the project's main job.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)"
exec build/bin/csm_cascades "$@"
