#!/usr/bin/env python3
"""Speed table of a `dslam ablate` study output folder (scripts/bench_speed.sh).

Per variant and dataset, over the repeats: median and range of wall frames/s,
median tracking time per frame (frame_ms of timing.csv), worst frame, largest
local BA, peak memory; with --reference FILE the ratio of the median frames/s
to the reference's (same variant and dataset). --save FILE writes the table
as CSV (to be used as the next reference). Standard library only.
"""
import argparse, csv, json, os, statistics, sys


def cell_rows(out):
    cells = os.path.join(out, "cells")
    if not os.path.isdir(cells):
        sys.exit(f"{out}: no cells/ folder (not a dslam ablate output)")
    for c in sorted(os.listdir(cells)):
        d = os.path.join(cells, c)
        try:
            with open(os.path.join(d, "result.json")) as f:
                r = json.load(f)
        except (OSError, ValueError):
            continue
        if r.get("status") != "ok":
            print(f"warning: cell {c} did not finish ({r.get('error', '')})", file=sys.stderr)
            continue
        frame, ba = [], []
        try:
            with open(os.path.join(d, "run", "timing.csv")) as f:
                for row in csv.DictReader(f):
                    if row.get("frame_ms"):
                        frame.append(float(row["frame_ms"]))
                    if row.get("local_ba_ms"):
                        ba.append(float(row["local_ba_ms"]))
        except OSError:
            pass
        yield {"variant": r["variant"], "dataset": r["dataset"], "fps": r.get("fps", 0.0),
               "median_ms": r.get("median_ms", 0.0), "worst_ms": max(frame) if frame else float("nan"),
               "max_ba_ms": max(ba) if ba else 0.0, "peak_mb": r.get("peak_mb", 0.0), "ate": r.get("ate_rmse")}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--reference")
    ap.add_argument("--save")
    a = ap.parse_args()
    groups = {}
    for r in cell_rows(a.out):
        groups.setdefault((r["variant"], r["dataset"]), []).append(r)
    if not groups:
        sys.exit(f"{a.out}: no finished cells")
    ref = {}
    if a.reference and os.path.exists(a.reference):
        with open(a.reference) as f:
            for row in csv.DictReader(f):
                ref[(row["variant"], row["dataset"])] = float(row["fps_median"])
    med = statistics.median
    table = []
    for (v, d), rs in sorted(groups.items()):
        fps = [r["fps"] for r in rs]
        ates = [r["ate"] for r in rs if r["ate"] is not None]
        table.append({"variant": v, "dataset": d, "runs": len(rs), "fps_median": med(fps), "fps_min": min(fps),
                      "fps_max": max(fps), "track_ms_median": med(r["median_ms"] for r in rs),
                      "worst_ms_median": med(r["worst_ms"] for r in rs), "worst_ms_max": max(r["worst_ms"] for r in rs),
                      "max_local_ba_ms": max(r["max_ba_ms"] for r in rs), "peak_mb_median": med(r["peak_mb"] for r in rs),
                      "ate_median": med(ates) if ates else float("nan"),
                      "fps_ratio_to_reference": (med(fps) / ref[(v, d)]) if (v, d) in ref else float("nan")})
    print("| variant | dataset | runs | frames/s median (min-max) | tracking ms median | worst frame ms (max) "
          "| largest local BA ms | peak MB | ATE m | frames/s / reference |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for t in table:
        print(f"| {t['variant']} | {t['dataset']} | {t['runs']} | {t['fps_median']:.1f} ({t['fps_min']:.1f}-{t['fps_max']:.1f}) "
              f"| {t['track_ms_median']:.1f} | {t['worst_ms_median']:.0f} ({t['worst_ms_max']:.0f}) | {t['max_local_ba_ms']:.0f} "
              f"| {t['peak_mb_median']:.0f} | {t['ate_median']:.4f} | {t['fps_ratio_to_reference']:.2f} |")
    if a.save:
        with open(a.save, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(table[0].keys()))
            w.writeheader()
            w.writerows(table)
        print(f"table saved to {a.save}", file=sys.stderr)


if __name__ == "__main__":
    main()
