#!/usr/bin/env python3
"""Error of every loop closure and map merge of a run (issue 12; docs/results.md section 7). numpy only, no dslam code.

  event_errors.py RUN_DIR GROUND_TRUTH [--after 30] [--max-dt 0.02]

For each "loop" / "merge" event of RUN_DIR/events.jsonl at frame F: the final
trajectory (RUN_DIR/trajectory.txt) is SE(3)-aligned on its poses before F
(Umeyama), and the position error of the poses from F on (the first --after
tracked ones) is printed: a correction that disagrees with the ground truth
leaves the part after the event offset from the part before (a merge 0.6 m
off: ~0.6 m). Frame numbers are the run's (frames.csv maps them to times).
Exit code 0; 'no loop or merge events' when there are none.
"""
import argparse
import json

import numpy as np


def read_tum(path):
    d = {}
    for l in open(path):
        if not l.strip() or l.lstrip().startswith("#"):
            continue
        v = l.replace(",", " ").split()
        d[float(v[0])] = np.array([float(x) for x in v[1:4]])
    return d


def align(P, Q):
    mp, mq = P.mean(0), Q.mean(0)
    U, _, Vt = np.linalg.svd((Q - mq).T @ (P - mp))
    D = np.eye(3)
    D[2, 2] = np.sign(np.linalg.det(U @ Vt))
    R = U @ D @ Vt
    return R, mq - R @ mp


def associate(est, gt, max_dt=0.02):
    """(t, estimate position, ground-truth position) of every estimate pose with a ground-truth pose within max_dt."""
    gts = np.array(sorted(gt))
    pairs = []
    for t in sorted(est):
        i = np.searchsorted(gts, t)
        best = min((j for j in (i - 1, i) if 0 <= j < len(gts)), key=lambda j: abs(gts[j] - t))
        if abs(gts[best] - t) < max_dt:
            pairs.append((t, est[t], gt[gts[best]]))
    return pairs


def errors(run, gt_file, after_n=30, max_dt=0.02):
    """One row per loop / merge event of RUN/events.jsonl: (event, frame, inliers, matches, correction_m,
    error at the event, max error over the next after_n poses, the event's position_sigma_m or nan)."""
    pairs = associate(read_tum(run + "/trajectory.txt"), read_tum(gt_file), max_dt)
    frame_t = {}
    for l in open(run + "/frames.csv"):
        v = l.strip().split(",")
        if v[0].isdigit():
            frame_t[int(v[0])] = float(v[1])
    rows = []
    for l in open(run + "/events.jsonl"):
        if not l.strip():
            continue
        e = json.loads(l)
        if e.get("event") not in ("loop", "merge"):
            continue
        tf = frame_t[e["frame"]]
        before = [p for p in pairs if p[0] < tf]
        after = [p for p in pairs if p[0] >= tf][:after_n]
        if len(before) < 3 or not after:
            continue
        R, t = align(np.array([p[1] for p in before]), np.array([p[2] for p in before]))
        err = [np.linalg.norm(R @ p[1] + t - p[2]) for p in after]
        rows.append((e["event"], e["frame"], e.get("inliers", -1), e.get("matches", -1),
                     e.get("correction_m", float("nan")), err[0], max(err), e.get("position_sigma_m", float("nan"))))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run")
    ap.add_argument("gt")
    ap.add_argument("--after", type=int, default=30)
    ap.add_argument("--max-dt", type=float, default=0.02)
    a = ap.parse_args()
    rows = errors(a.run, a.gt, a.after, a.max_dt)
    if not rows:
        print("no loop or merge events")
        return
    print("event  frame  inliers/matches  correction_m  error_at_event_m  max_error_next_%d_m  position_sigma_m"
          % a.after)
    for r in rows:
        print("%-6s %5d  %4d/%-4d        %8.3f      %8.3f          %8.3f             %8.3f" % r)


if __name__ == "__main__":
    main()
