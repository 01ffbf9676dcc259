#!/usr/bin/env python3
"""Plot a dslam trajectory evaluation.

Reads the CSV written by `dslam eval ate|rpe --plot FILE.png` (columns
t,gt_x,gt_y,gt_z,est_x,est_y,est_z,error; one row per associated pose pair,
estimate already aligned) and draws ground truth vs estimate in the xy and xz
planes and the error over time into one PNG.

Usage: plot_trajectory.py --csv FILE.csv --out FILE.png [--title T] [--error-label L]
Needs matplotlib (Debian/Ubuntu: apt-get install python3-matplotlib).
"""
import argparse
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--csv", required=True, help="data written by dslam eval --plot")
    ap.add_argument("--out", required=True, help="output image (PNG)")
    ap.add_argument("--title", default="trajectory evaluation")
    ap.add_argument("--error-label", default="error [m]")
    a = ap.parse_args()

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import numpy as np
    except ImportError as e:
        sys.exit(f"plot_trajectory.py: {e}; install matplotlib (apt-get install python3-matplotlib)")

    d = np.genfromtxt(a.csv, delimiter=",", names=True)
    d = np.atleast_1d(d)
    if d.size == 0:
        sys.exit(f"plot_trajectory.py: no data rows in {a.csv}")
    t = d["t"] - d["t"][0]

    fig, ax = plt.subplots(1, 3, figsize=(16, 5))
    for k, (u, v) in enumerate((("x", "y"), ("x", "z"))):
        ax[k].plot(d["gt_" + u], d["gt_" + v], "-", color="0.3", lw=1.5, label="ground truth")
        ax[k].plot(d["est_" + u], d["est_" + v], "-", color="tab:blue", lw=1.0, label="estimate (aligned)")
        ax[k].set_xlabel(f"{u} [m]")
        ax[k].set_ylabel(f"{v} [m]")
        ax[k].set_title(f"{u}{v} view")
        ax[k].set_aspect("equal", adjustable="datalim")
        ax[k].grid(True, alpha=0.3)
        ax[k].legend(loc="best", fontsize=8)
    ok = np.isfinite(d["error"])
    ax[2].plot(t[ok], d["error"][ok], "-", color="tab:red", lw=1.0, label="per pair")
    if ok.any():
        rmse = float(np.sqrt(np.mean(d["error"][ok] ** 2)))
        ax[2].axhline(rmse, color="k", ls="--", lw=0.8, label=f"RMSE {rmse:.4g}")
        ax[2].legend(loc="best", fontsize=8)
    ax[2].set_xlabel("time [s]")
    ax[2].set_ylabel(a.error_label)
    ax[2].set_title("error over time")
    ax[2].grid(True, alpha=0.3)
    fig.suptitle(a.title)
    fig.tight_layout()
    fig.savefig(a.out, dpi=90)
    return 0


if __name__ == "__main__":
    sys.exit(main())
