#!/usr/bin/env bash
# The fly-through against the Sascha Willems shadowmappingcascade sample, interleaved rounds
# (tools/peer/README.md). Usage: tools/peer/compare.sh SASCHA_DIR OUT [ROUNDS]
#   SASCHA_DIR: a checkout patched by patch_sascha.py and built (build/bin/shadowmappingcascade,
#               assets/ beside it); OUT: a directory for the runs; ROUNDS: default 3.
# Each round: ours with the cache, theirs without anisotropy, ours with receiver-marked tiles,
# theirs with its 8x anisotropy. Then tools/peer/summarise.py OUT prints the table.
set -euo pipefail
[[ $# -ge 2 ]] || { echo "usage: $0 SASCHA_DIR OUT [ROUNDS]" >&2; exit 2; }
sascha=$(cd "$1" && pwd) out=$2 rounds=${3:-3}
repo=$(cd "$(dirname "$0")/../.." && pwd)
ours=$repo/build/bin/csm_flythrough
[[ -x $ours ]] || { echo "$ours: build the project first (tools/run.sh or cmake --build)" >&2; exit 2; }
[[ -x $sascha/build/bin/shadowmappingcascade ]] ||
  { echo "$sascha/build/bin/shadowmappingcascade: not built" >&2; exit 2; }
mkdir -p "$out"
out=$(cd "$out" && pwd)
flight=(--headless --frames 30 --shot-every 1000 --path forest --set shadow.resolution=4096
        --set view.deferred=true)
for ((r = 1; r <= rounds; ++r)); do
  for what in ours-cache theirs-a1 ours-tiles theirs-a8; do
    d=$out/$what-$r
    rm -rf "$d" && mkdir -p "$d"
    case $what in
      ours-cache) "$ours" "${flight[@]}" --out "$d" >"$d.log" 2>&1 ;;
      ours-tiles) "$ours" "${flight[@]}" --set shadow.tiles=true --out "$d" >"$d.log" 2>&1 ;;
      theirs-a*)
        (cd "$sascha" && SASCHA_ANISO=${what#theirs-a} SASCHA_TS=$d/ts.txt xvfb-run -a \
           build/bin/shadowmappingcascade -b -bw 2 -br 30 -w 1280 -h 720 -bt -bf "$d/bench.txt" \
           >"$d.log" 2>&1) ;;
    esac
    echo "round $r: $what done, load $(cut -d' ' -f1 /proc/loadavg)" >&2
  done
done
