#!/usr/bin/env bash
# The cache's cost, measured as users run it: csm_flythrough on every path with shadow.cache on
# and off, interleaved in rounds (on, off, on, off, ... per path and round, so that the machine's
# load falls on both alike), and per path the median over rounds of each run's median and 99th
# percentile of the shadow pass and of the whole GPU frame (report.json's summary; the first
# frame and screenshot frames left out). Prints a markdown table; the runs stay in OUT.
#   tools/bench/cache_flights.sh [--frames N] [--rounds R] [--out DIR] [--paths a,b,...]
#                                [--set key=value ...]
# Defaults: 40 frames, 2 rounds, the paths forest, fast, rotate, zoom, far and cables, 1280x720
# and every other fly-through default. The day and cut paths run on a 60 frames a second clock:
# give them frames enough for their light steps and cuts (a 1200 s day steps the sun's 0.25°
# about every 100 frames; a cut every second is every 60 frames).
set -euo pipefail
cd "$(dirname "$0")/../.."
frames=40 rounds=2 out=build/cache_flights extra=() pathList=forest,fast,rotate,zoom,far,cables
while [[ $# -gt 0 ]]; do
  case "$1" in
    --frames) frames="$2"; shift 2 ;;
    --rounds) rounds="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --paths) pathList="$2"; shift 2 ;;
    --set) extra+=(--set "$2"); shift 2 ;;
    *) echo "cache_flights.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
[[ "$frames" =~ ^[0-9]+$ && "$frames" -ge 3 ]] || { echo "--frames: a whole number >= 3" >&2; exit 2; }
[[ "$rounds" =~ ^[0-9]+$ && "$rounds" -ge 1 ]] || { echo "--rounds: a whole number >= 1" >&2; exit 2; }
command -v jq >/dev/null || { echo "cache_flights.sh: needs jq (tools/setup.sh installs it)" >&2; exit 1; }
app=build/bin/csm_flythrough
[[ -x "$app" ]] || { echo "cache_flights.sh: build first ($app missing)" >&2; exit 1; }
IFS=, read -r -a paths <<<"$pathList"
for p in "${paths[@]}"; do
  [[ "$p" =~ ^(forest|fast|rotate|zoom|far|cables|day|cut)$ ]] ||
    { echo "--paths: '$p' is not one of forest, fast, rotate, zoom, far, cables, day, cut" >&2; exit 2; }
done
mkdir -p "$out"
for ((r = 1; r <= rounds; ++r)); do
  for p in "${paths[@]}"; do
    for c in true false; do
      dir="$out/$p-cache_$c-r$r"
      rm -rf "$dir"
      echo "round $r/$rounds: $p, cache $c" >&2
      "$app" --headless --frames "$frames" --shot-every 100000 --path "$p" --out "$dir" \
        --set shadow.cache=$c "${extra[@]}" >/dev/null
    done
  done
done
median() { sort -g | awk '{a[NR] = $1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }
field() { for ((r = 1; r <= rounds; ++r)); do jq ".summary.$3" "$out/$1-cache_$2-r$r/report.json"; done | median; }
device=$(jq -r .device "$out/${paths[0]}-cache_true-r1/report.json")
echo "$device; $frames frames per run, $rounds interleaved rounds; ms, median over rounds"
echo
echo "| path | shadow median on / off | ratio | shadow p99 on / off | ratio | frame median on / off | frame p99 on / off | cuts, light steps |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|"
for p in "${paths[@]}"; do
  sm1=$(field "$p" true gpu_shadow_ms_median) sm0=$(field "$p" false gpu_shadow_ms_median)
  sp1=$(field "$p" true gpu_shadow_ms_p99) sp0=$(field "$p" false gpu_shadow_ms_p99)
  fm1=$(field "$p" true gpu_frame_ms_median) fm0=$(field "$p" false gpu_frame_ms_median)
  fp1=$(field "$p" true gpu_frame_ms_p99) fp0=$(field "$p" false gpu_frame_ms_p99)
  events=$(jq -r '"\(.summary.camera_cuts // 0), \(.summary.light_steps // 0)"' \
    "$out/$p-cache_true-r1/report.json")
  awk -v p="$p" -v a="$sm1" -v b="$sm0" -v c="$sp1" -v d="$sp0" -v e="$fm1" -v f="$fm0" \
    -v g="$fp1" -v h="$fp0" -v ev="$events" 'BEGIN {
      printf "| %s | %.1f / %.1f | %.2fx | %.1f / %.1f | %.2fx | %.1f / %.1f | %.1f / %.1f | %s |\n",
        p, a, b, (a > 0 ? b / a : 0), c, d, (c > 0 ? d / c : 0), e, f, g, h, ev }'
done
