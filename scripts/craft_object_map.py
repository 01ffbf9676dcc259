#!/usr/bin/env python3
"""Crafts a run folder for `dslam eval objects` from a `dslam synth` scene.

Writes OUT/objects.json ("dslam-objects" version 1) and OUT/trajectory.txt
(TUM) as a run would, from the scene's ground truth: one object per labelled
COCO thing seen >= 2000 px, its centroid the mean of points sampled on the box
faces that face the camera in the frame where the object is most visible
(1 cm noise), the trajectory the ground truth with 5 mm noise, both in a frame
offset by a fixed SE(3) (rotation (35, 5, -3) deg zyx, translation
(0.7, -1.2, 0.3) m) that the evaluation's alignment must undo.

  updated: the map followed every change (objects at the places they left
           are inactive, moved / new objects mapped at their end place);
  stale:   the map noticed none (every object at its first place, active).

Usage: craft_object_map.py SCENE_DIR OUT_DIR updated|stale
Needs numpy and scipy (Debian/Ubuntu: apt-get install python3-numpy python3-scipy).
The numbers it gives are in docs/evaluation.md ("Measured: crafted maps").
"""
import json
import os
import sys

import numpy as np
from scipy.spatial.transform import Rotation as Rot

if len(sys.argv) != 4 or sys.argv[3] not in ("updated", "stale"):
    sys.exit(__doc__)
scene, out, mode = sys.argv[1], sys.argv[2], sys.argv[3]
os.makedirs(out, exist_ok=True)
sc = json.load(open(scene + '/objects.json'))
gt = np.loadtxt(scene + '/groundtruth.txt')
rng = np.random.default_rng(1)
T_ew_R = Rot.from_euler('zyx', [35, 5, -3], degrees=True).as_matrix(); T_ew_t = np.array([0.7, -1.2, 0.3])
def to_est(p): return T_ew_R @ p + T_ew_t
def pose_at(o, f):
    T = o['track'][0]
    for e in o['track']:
        if e[0] <= f: T = e
    return np.array(T[1:4]), Rot.from_quat(T[4:8]).as_matrix()
def surface_centroid(o, f0, f1):
    vis = o['visible_pixels']
    f = max(range(f0, f1 + 1), key=lambda k: vis[k])
    t, R = pose_at(o, f)
    cam = gt[f, 1:4]
    s = np.array(o['size']); c = t + R @ np.array([0, 0, s[2] / 2])
    pts = []
    for ax in range(3):
        for sg in (-1, 1):
            n = R[:, ax] * sg
            fc = c + n * s[ax] / 2
            if np.dot(cam - fc, n) <= 0: continue
            for _ in range(int(200 * np.prod([s[k] for k in range(3) if k != ax]) / 0.1) + 5):
                u = (rng.random(3) - 0.5) * s; u[ax] = sg * s[ax] / 2
                pts.append(t + R @ (u + np.array([0, 0, s[2] / 2])))
    pts = np.array(pts) + rng.normal(0, 0.01, (len(pts), 3))
    return pts.mean(0), pts.min(0), pts.max(0), len(pts), f
# COCO things of the lab scenes (chair, suitcase, potted plant, backpack, tv, dining table, microwave)
things = {62, 33, 64, 27, 72, 67, 78}
ev = {e['object']: e for e in sc['events']}
byev = {e['by']: e for e in sc['events'] if 'by' in e}
objs = []; k = 0
for o in sc['objects']:
    if o['category_id'] not in things or sum(o['visible_pixels']) < 2000: continue
    e = ev.get(o['name'])
    places = []
    if e and e['type'] == 'moved':
        places.append((0, e['frames'][0] - 1, mode == 'stale'))  # old place: active only if the map never noticed
        if mode == 'updated': places.append((e['frames'][1], sc['frames'] - 1, True))
    elif e and e['type'] in ('removed', 'replaced'):
        places.append((0, e['frames'][0] - 1, mode == 'stale'))
    elif o['name'] in byev:
        if mode == 'updated': places.append((byev[o['name']]['frames'][0], sc['frames'] - 1, True))
    else:
        places.append((0, sc['frames'] - 1, True))
    for f0, f1, active in places:
        c, lo, hi, n, f = surface_centroid(o, f0, f1)
        k += 1
        objs.append({"id": k, "map": 0, "class_id": o['category_id'], "class": o['class'],
                     "centroid": list(to_est(c)), "box_min": list(to_est(lo)), "box_max": list(to_est(hi)),
                     "points": n, "belief": 0.9 if active else 0.1, "active": active,
                     "first_seen_kf": f0 // 10, "last_seen_kf": f1 // 10, "first_seen_t": gt[f0, 0], "last_seen_t": gt[f1, 0],
                     "sightings": 5})
json.dump({"format": "dslam-objects", "version": 1, "map": 0, "objects": objs}, open(out + '/objects.json', 'w'), indent=1)
with open(out + '/trajectory.txt', 'w') as fo:
    for r in gt:
        R = T_ew_R @ Rot.from_quat(r[4:8]).as_matrix(); t = to_est(r[1:4]) + rng.normal(0, 0.005, 3)
        fo.write('%.9f %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n' % (r[0], *t, *Rot.from_matrix(R).as_quat()))
print(len(objs), 'objects ->', out)
