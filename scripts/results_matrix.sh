#!/usr/bin/env bash
# Runs every pipeline on every synthetic scenario and prints a Markdown table
# (ATE RMSE in metres, tracked frames, median tracking ms, frames/s). Scenes
# are rendered once into $WORK/scenes (default out/matrix).
#
#   scripts/results_matrix.sh [--frames N] [--resolution WxH] [--work DIR] \
#       --pipelines a.yaml b.yaml ... --scenarios walking_xyz walking_rpy ...
set -euo pipefail
cd "$(dirname "$0")/.."
FRAMES=""
RES=""
WORK=out/matrix
PIPES=()
SCENES=()
mode=""
while [ $# -gt 0 ]; do
  case "$1" in
    --frames) FRAMES="$2"; shift 2 ;;
    --resolution) RES="$2"; shift 2 ;;
    --work) WORK="$2"; shift 2 ;;
    --pipelines) mode=p; shift ;;
    --scenarios) mode=s; shift ;;
    *) if [ "$mode" = p ]; then PIPES+=("$1"); elif [ "$mode" = s ]; then SCENES+=("$1"); else
         echo "usage: $0 [--frames N] [--resolution WxH] [--work DIR] --pipelines ... --scenarios ..." >&2; exit 2; fi
       shift ;;
  esac
done
DSLAM=${DSLAM:-build/bin/dslam}
mkdir -p "$WORK/scenes" "$WORK/runs"
for s in "${SCENES[@]}"; do
  dir="$WORK/scenes/$s${FRAMES:+_$FRAMES}${RES:+_$RES}"
  if [ ! -f "$dir/groundtruth.txt" ]; then
    "$DSLAM" synth "config/scenarios/$s.yaml" --out "$dir" --overwrite ${FRAMES:+--frames $FRAMES} ${RES:+--resolution $RES} >&2
  fi
done
for s in "${SCENES[@]}"; do
  dir="$WORK/scenes/$s${FRAMES:+_$FRAMES}${RES:+_$RES}"
  for p in "${PIPES[@]}"; do
    name=$(basename "$p" .yaml)
    out="$WORK/runs/$s/$name"
    mkdir -p "$WORK/runs/$s"
    echo "== $name on $s" >&2
    "$DSLAM" run "$p" --dataset "$dir" --out "$out" --no-progress > "$out.log" 2>&1 || echo "   FAILED (see $out.log)" >&2
  done
done
/usr/bin/env python3 - "$WORK" "${#PIPES[@]}" "${PIPES[@]}" "${SCENES[@]}" <<'PY'
import json, os, sys
work = sys.argv[1]; n = int(sys.argv[2]); pipes = [os.path.basename(p)[:-5] for p in sys.argv[3:3 + n]]; scenes = sys.argv[3 + n:]
print("| scenario | " + " | ".join(pipes) + " |")
print("|---|" + "---|" * len(pipes))
for s in scenes:
    cells = []
    for p in pipes:
        f = os.path.join(work, "runs", s, p, "summary.json")
        if not os.path.exists(f):
            cells.append("failed"); continue
        j = json.load(open(f))
        ate = j.get("ate_rmse")
        lost = j["frames"] - j["tracked"]
        cells.append(("%.4f" % ate if ate is not None else "n/a") + (" (%d lost)" % lost if lost else "") +
                     " / %.1f fps" % j["fps"])
    print("| %s | %s |" % (s, " | ".join(cells)))
PY
