#!/usr/bin/env bash
# Windowed smoke test of csm_flythrough: under a virtual X server, 30 frames with a resize and a
# minimise/restore, validation on; exit 0 required (which includes zero validation messages).
# Exit 77 (skipped) when Xvfb is not installed.
set -euo pipefail
exe="$1"
if ! command -v xvfb-run >/dev/null 2>&1 || ! command -v Xvfb >/dev/null 2>&1; then
  echo "xvfb-run/Xvfb not installed: skipping the windowed smoke test"
  exit 77
fi
exec xvfb-run -a -s "-screen 0 1280x720x24" "$exe" --window --frames 30 --smoke-test \
  --validation --set view.width=320 --set view.height=180 --set shadow.resolution=512 \
  --set world.trees=3000
