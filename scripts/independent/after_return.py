#!/usr/bin/env python3
"""Pose error after a return (docs/results.md section 7): SE(3)-align the estimate on the poses before ALIGN_UNTIL, then the max / median
position error of the first N poses from RETURN_T on. Usage: after_return.py GT EST ALIGN_UNTIL RETURN_T N (TUM files; numpy)."""
import sys

import numpy as np

from event_errors import align, associate, read_tum


def after_return(gt_file, est_file, until, ret, n):
    """Errors of every associated pose (t, error), of the alignment poses and of the first n poses from `ret` on."""
    gt = read_tum(gt_file)
    pairs = associate(read_tum(est_file), gt)
    before = [p for p in pairs if p[0] < until]
    R, t = align(np.array([p[1] for p in before]), np.array([p[2] for p in before]))
    err = [(p[0], np.linalg.norm(R @ p[1] + t - p[2])) for p in pairs]
    return err, [e for x, e in err if x < until], [e for x, e in err if x >= ret][:n], len(gt)


def main():
    gt_f, est_f, until, ret, n = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5])
    err, before, after, n_gt = after_return(gt_f, est_f, until, ret, n)
    print("before-change rmse %.4f m; %d frames after return: max %.3f m, median %.3f m; all-frames rmse %.4f m; "
          "tracked %d/%d" % (np.sqrt(np.mean(np.square(before))), len(after), max(after) if after else -1,
                             np.median(after) if after else -1, np.sqrt(np.mean([e**2 for _, e in err])), len(err),
                             n_gt))


if __name__ == "__main__":
    main()
