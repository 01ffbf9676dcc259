#!/usr/bin/env python3
"""Independent ATE check (numpy only, no dslam code), to cross-check `dslam eval ate`.

  umeyama_ate.py GROUND_TRUTH ESTIMATE [--rate 10] [--max-dt 0.02]

Files: TUM (t x y z qx qy qz qw) or KITTI 12-column poses (t = i / rate).
Associates each estimate pose with the nearest ground-truth time (|dt| <
max_dt), aligns the positions with Umeyama's least squares (SE(3), then
Sim(3) with scale) and prints the RMSE, the maximum and the scale.
"""
import argparse

import numpy as np


def read(path, rate):
    rows = [l.split() for l in open(path) if l.strip() and not l.lstrip().startswith("#")]
    if len(rows[0]) == 12:
        p = np.array([[float(x) for x in r] for r in rows])
        return np.arange(len(p)) / rate, p[:, [3, 7, 11]]
    a = np.array([[float(x) for x in r[:8]] for r in rows])
    return a[:, 0], a[:, 1:4]


def umeyama(src, dst, with_scale):
    mu_s, mu_d = src.mean(0), dst.mean(0)
    xs, xd = src - mu_s, dst - mu_d
    u, d, vt = np.linalg.svd(xd.T @ xs / len(src))
    s = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        s[2, 2] = -1
    r = u @ s @ vt
    c = np.trace(np.diag(d) @ s) / (xs ** 2).sum(1).mean() if with_scale else 1.0
    return c, r, mu_d - c * r @ mu_s


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("gt")
    ap.add_argument("est")
    ap.add_argument("--rate", type=float, default=10.0, help="KITTI files without times: frames per second")
    ap.add_argument("--max-dt", type=float, default=0.02)
    a = ap.parse_args()
    gt_t, gt_p = read(a.gt, a.rate)
    es_t, es_p = read(a.est, a.rate)
    pairs = [(int(np.argmin(abs(gt_t - t))), j) for j, t in enumerate(es_t)]
    pairs = [(i, j) for i, j in pairs if abs(gt_t[i] - es_t[j]) < a.max_dt]
    g, e = gt_p[[i for i, _ in pairs]], es_p[[j for _, j in pairs]]
    for name, with_scale in (("se3", False), ("sim3", True)):
        c, r, t = umeyama(e, g, with_scale)
        err = np.linalg.norm((c * (r @ e.T)).T + t - g, axis=1)
        print(f"{name}: {len(pairs)} pairs, rmse {np.sqrt((err ** 2).mean()):.4f} m, max {err.max():.4f} m, scale {c:.4f}")
    lg, le = (np.linalg.norm(np.diff(x, axis=0), axis=1).sum() for x in (g, e))
    print(f"path length: ground truth {lg:.2f} m, estimate {le:.2f} m (estimate / ground truth {le / lg:.4f})")


if __name__ == "__main__":
    main()
