#!/usr/bin/env python3
"""Active objects by verdict and number of sightings (docs/results.md section 7).

  object_sightings.py STUDY_OUT [STUDY_OUT ...] [--dslam build/bin/dslam] [--variants-prefix changing_slam]

For every cell STUDY_OUT/cells/<variant>.<dataset>.r0 whose variant starts
with the prefix and whose dataset is a synthetic scene (objects.json): runs
`dslam eval objects RUN SCENE --json` and counts the active estimated
objects by verdict (match, stale, false) and by sightings (1, 2, 3 or more;
objects.json of the run), and the single-sighting matches by the fate of
the ground-truth object (static, moved). What "write an object only once a
second keyframe saw it" would remove.
"""
import argparse
import collections
import glob
import json
import os

from changing_tables import eval_objects


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", nargs="+")
    ap.add_argument("--dslam", default="build/bin/dslam")
    ap.add_argument("--variants-prefix", default="changing_slam")
    a = ap.parse_args()
    by_sightings, single_match = collections.Counter(), collections.Counter()
    for study in a.out:
        for cell in sorted(glob.glob(os.path.join(study, "cells", a.variants_prefix + "*.r0"))):
            scene = json.load(open(os.path.join(cell, "cell.json"))).get("dataset_path", "")
            run = os.path.join(cell, "run")
            if not os.path.exists(os.path.join(scene, "objects.json")) or not os.path.exists(run + "/objects.json"):
                continue
            ev = eval_objects(a.dslam, run, scene)
            if ev is None:
                continue
            objs = {o["id"]: o for o in json.load(open(run + "/objects.json"))["objects"]}
            fate = {g["instance_id"]: g["fate"] for g in ev["ground_truth"]}
            for e in ev["estimates"]:
                o = objs.get(e["id"])
                if not o or not e["active"]:
                    continue
                n = min(o["sightings"], 3)
                by_sightings[(e["verdict"], n)] += 1
                if e["verdict"] == "match" and n == 1:
                    single_match[fate.get(e.get("instance_id"), "?")] += 1
    print("| verdict | 1 sighting | 2 | 3 or more |")
    print("|---|---|---|---|")
    for v in sorted({k[0] for k in by_sightings}):
        print("| %s | %d | %d | %d |" % (v, by_sightings[(v, 1)], by_sightings[(v, 2)], by_sightings[(v, 3)]))
    print("\nsingle-sighting matches by fate: " + ", ".join("%s %d" % kv for kv in sorted(single_match.items())))


if __name__ == "__main__":
    main()
