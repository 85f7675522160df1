#!/usr/bin/env python3
"""The table of tools/peer/compare.sh's runs: tools/peer/summarise.py OUT.

Ours: report.json's wall_frame_ms_median (frames 1-29) and the per-frame GPU scopes' medians
(shadow, G-buffer, lighting, tile marks). Theirs: the median of the per-frame times its
benchmark mode writes after the warm-up, and of its timestamps (shadow passes, scene pass),
the first two frames left out."""
import json
import os
import statistics
import sys

if len(sys.argv) != 2:
    sys.exit("usage: summarise.py OUT")
out = sys.argv[1]


def median(xs):
    return statistics.median(xs) if xs else float("nan")


def ours(d):
    rep = json.load(open(os.path.join(d, "report.json")))
    frames = rep["per_frame"][1:]
    gpu = lambda k: median([f["gpu_ms"].get(k, 0.0) for f in frames])
    return dict(wall=rep["summary"]["wall_frame_ms_median"], shadow=gpu("shadow"),
                gbuffer=gpu("gbuffer"), lit=gpu("lit"), marks=gpu("tile marks"))


def theirs(d):
    lines = open(os.path.join(d, "bench.txt")).read().split("\n")
    times = [float(l.split(",")[1]) for l in lines[lines.index("frame,ms") + 1:] if l.strip()]
    ts = [tuple(map(float, l.split())) for l in open(os.path.join(d, "ts.txt")) if l.strip()][2:]
    return dict(wall=median(times), frames=len(times), shadow=median([a for a, _ in ts]),
                lit=median([b for _, b in ts]))


print("| round | ours, cache (shadow / G-buffer / lighting) | ours, tiles (shadow / G-buffer / "
      "lighting / marks) | theirs, no anisotropy (shadow / scene, frames) | theirs, 8x "
      "anisotropy (shadow / scene, frames) | cache / theirs | tiles / theirs | tiles / theirs 8x |")
print("|---|---:|---:|---:|---:|---:|---:|---:|")
r = 1
while os.path.isdir(os.path.join(out, f"ours-cache-{r}")):
    try:
        oc, ot = ours(os.path.join(out, f"ours-cache-{r}")), ours(os.path.join(out, f"ours-tiles-{r}"))
        t1, t8 = theirs(os.path.join(out, f"theirs-a1-{r}")), theirs(os.path.join(out, f"theirs-a8-{r}"))
    except (OSError, ValueError, KeyError) as e:
        sys.exit(f"round {r}: {e}")
    print(f"| {r} | {oc['wall']:.1f} ({oc['shadow']:.1f} / {oc['gbuffer']:.1f} / {oc['lit']:.1f}) "
          f"| {ot['wall']:.1f} ({ot['shadow']:.1f} / {ot['gbuffer']:.1f} / {ot['lit']:.1f} / "
          f"{ot['marks']:.1f}) | {t1['wall']:.1f} ({t1['shadow']:.1f} / {t1['lit']:.1f}, "
          f"{t1['frames']}) | {t8['wall']:.1f} ({t8['shadow']:.1f} / {t8['lit']:.1f}, "
          f"{t8['frames']}) | {oc['wall'] / t1['wall']:.3f}x | {ot['wall'] / t1['wall']:.3f}x | "
          f"{ot['wall'] / t8['wall']:.3f}x |")
    r += 1
