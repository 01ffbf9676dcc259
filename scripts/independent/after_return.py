#!/usr/bin/env python3
"""Pose error after a return (docs/results.md section 7): SE(3)-align the estimate on the poses before ALIGN_UNTIL, then the max / median
position error of the first N poses from RETURN_T on. Usage: after_return.py GT EST ALIGN_UNTIL RETURN_T N (TUM files; numpy)."""
import sys, numpy as np
gt_f, est_f, until, ret, n = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5])
def load(f):
    d = {}
    for l in open(f):
        if l.startswith('#') or not l.strip(): continue
        v = l.replace(',', ' ').split()
        d[round(float(v[0]), 4)] = np.array([float(x) for x in v[1:4]])
    return d
g, e = load(gt_f), load(est_f)
ts = sorted(t for t in e if t in g)
A = [t for t in ts if t < until]
P = np.array([e[t] for t in A]).T; Q = np.array([g[t] for t in A]).T
mp, mq = P.mean(1, keepdims=True), Q.mean(1, keepdims=True)
U, S, Vt = np.linalg.svd((Q - mq) @ (P - mp).T)
D = np.eye(3); D[2, 2] = np.sign(np.linalg.det(U @ Vt))
R = U @ D @ Vt; t = mq - R @ mp
err = {x: np.linalg.norm(R @ e[x] + t[:, 0] - g[x]) for x in ts}
after = [x for x in ts if x >= ret][:n]
print("before-change rmse %.4f m; %d frames after return: max %.3f m, median %.3f m; all-frames rmse %.4f m; tracked %d/%d" % (
    np.sqrt(np.mean([err[x]**2 for x in A])), len(after), max(err[x] for x in after) if after else -1,
    np.median([err[x] for x in after]) if after else -1, np.sqrt(np.mean([v**2 for v in err.values()])), len(ts), len(g)))
