#!/usr/bin/env python3
"""Plots of a dslam ablation study (written by `dslam ablate`, docs/ablation.md).

  plot_study.py ate  --csv plots/ate.csv --out plots/ate.png [--title T]
      grouped bars: median ATE per variant and dataset, the range over the
      runs as error bars (columns variant,dataset,n,median,min,max).
  plot_study.py traj --csv plots/trajectories_D.csv --out plots/trajectories_D.png [--title T]
      top view of the ground truth and every variant's aligned trajectory
      (columns label,x,y,z; label 'ground truth' for the reference). The two
      axes with the largest extent of the ground truth are drawn (the floor
      plane for a camera moving mostly horizontally).

Needs matplotlib (Debian/Ubuntu: apt-get install python3-matplotlib).
"""
import argparse
import csv
import sys
from collections import OrderedDict


def load(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def plot_ate(rows, out, title, plt):
    datasets = list(OrderedDict.fromkeys(r["dataset"] for r in rows))
    variants = list(OrderedDict.fromkeys(r["variant"] for r in rows))
    if not rows:
        sys.exit("plot_study.py: no ATE rows")
    by = {(r["variant"], r["dataset"]): r for r in rows}
    n = len(variants)
    width = 0.8 / max(1, n)
    fig, ax = plt.subplots(figsize=(max(6, 1.2 * len(datasets) * max(1, n) * 0.6 + 2), 4.5))
    for k, v in enumerate(variants):
        xs, ys, lo, hi = [], [], [], []
        for i, d in enumerate(datasets):
            r = by.get((v, d))
            if not r:
                continue
            m, a, b = float(r["median"]), float(r["min"]), float(r["max"])
            xs.append(i - 0.4 + width * (k + 0.5))
            ys.append(m)
            lo.append(m - a)
            hi.append(b - m)
        ax.bar(xs, ys, width * 0.9, yerr=[lo, hi], capsize=3, label=v)
    ax.set_xticks(range(len(datasets)))
    ax.set_xticklabels(datasets, rotation=20 if len(datasets) > 4 else 0)
    ax.set_ylabel("ATE RMSE [m]")
    positive = [float(r["median"]) for r in rows if float(r["median"]) > 0]
    if positive and max(positive) / min(positive) > 30:
        ax.set_yscale("log")
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(out, dpi=90)


def plot_traj(rows, out, title, plt, np):
    series = OrderedDict()
    for r in rows:
        series.setdefault(r["label"], []).append((float(r["x"]), float(r["y"]), float(r["z"])))
    if not series:
        sys.exit("plot_study.py: no trajectory rows")
    ref = np.array(series.get("ground truth") or next(iter(series.values())))
    axes = sorted(np.argsort(ref.std(axis=0))[-2:])
    names = "xyz"
    fig, ax = plt.subplots(figsize=(7, 6))
    for label, pts in series.items():
        p = np.array(pts)
        if label == "ground truth":
            ax.plot(p[:, axes[0]], p[:, axes[1]], "-", color="0.2", lw=2.0, label=label, zorder=1)
        else:
            ax.plot(p[:, axes[0]], p[:, axes[1]], "-", lw=1.0, label=label, zorder=2)
    ax.set_xlabel(f"{names[axes[0]]} [m]")
    ax.set_ylabel(f"{names[axes[1]]} [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=90)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kind", choices=["ate", "traj"])
    ap.add_argument("--csv", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--title", default="")
    a = ap.parse_args()
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import numpy as np
    except ImportError as e:
        sys.exit(f"plot_study.py: {e}; install matplotlib (apt-get install python3-matplotlib)")
    rows = load(a.csv)
    if a.kind == "ate":
        plot_ate(rows, a.out, a.title, plt)
    else:
        plot_traj(rows, a.out, a.title, plt, np)
    return 0


if __name__ == "__main__":
    sys.exit(main())
