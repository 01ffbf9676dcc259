#!/usr/bin/env bash
# Regenerates the tables of docs/results.md from the study files in
# config/studies and a few commands. Each table sits between
#   <!-- results.sh:NAME begin --> ... <!-- results.sh:NAME end -->
# markers and is replaced with the commands that produce it, the dslam
# version and git commit that ran them, and the table.
#
#   scripts/results.sh [--work DIR] [--jobs N] [--dry-run] [SECTION ...]
#
# Sections (default: all): matrix (config/studies/dynamic_matrix.yaml),
# ablation (afc_repopulation.yaml), static (static_scenes.yaml), kitti (the
# KITTI clip with SE(3) and Sim(3) alignment), speed (speed.yaml).
# Runs go to WORK/<commit>/<section> (default WORK: out/results) and are
# resumed there (`dslam ablate --resume`): an interrupted regeneration
# continues, a new commit starts afresh. --dry-run prints the commands.
set -euo pipefail
cd "$(dirname "$0")/.."
WORK=out/results
JOBS=${DSLAM_JOBS:-2}
DRY=0
SECTIONS=()
while [ $# -gt 0 ]; do
  case "$1" in
    --work) WORK="$2"; shift 2 ;;
    --jobs) JOBS="$2"; shift 2 ;;
    --dry-run) DRY=1; shift ;;
    -h|--help) sed -n '2,17p' "$0"; exit 0 ;;
    matrix|ablation|static|kitti|speed) SECTIONS+=("$1"); shift ;;
    *) echo "results.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ ${#SECTIONS[@]} -gt 0 ] || SECTIONS=(matrix ablation static kitti speed)
DSLAM=${DSLAM:-build/bin/dslam}
[ -x "$DSLAM" ] || { echo "results.sh: $DSLAM not found: run scripts/build.sh" >&2; exit 1; }
export DSLAM_SHARED_DIR="${DSLAM_SHARED_DIR:-$(cd .. && pwd)/shared}"
VERSION=$("$DSLAM" --version)
COMMIT=$(sed -n 's/.*(commit \(.*\)).*/\1/p' <<< "$VERSION")
HEAD=$(git rev-parse --short=12 HEAD 2> /dev/null || echo unknown)
if [ "${COMMIT%-modified}" != "$HEAD" ]; then
  echo "results.sh: $DSLAM was built from commit $COMMIT, the checkout is at $HEAD: run scripts/build.sh first" >&2
  exit 1
fi
OUT="$WORK/$COMMIT"
DOC=docs/results.md
mkdir -p "$OUT"

run() { echo "+ $*" >&2; if [ "$DRY" = 0 ]; then "$@"; fi; }

# replace_block NAME FILE: puts FILE's content between the NAME markers of $DOC.
replace_block() {
  [ "$DRY" = 1 ] && return 0
  python3 - "$DOC" "$1" "$2" <<'PY'
import sys
doc, name, body = sys.argv[1], sys.argv[2], open(sys.argv[3]).read().rstrip("\n")
text = open(doc).read()
b, e = f"<!-- results.sh:{name} begin -->", f"<!-- results.sh:{name} end -->"
if b not in text or e not in text:
    sys.exit(f"results.sh: markers of '{name}' not found in {doc}")
i, j = text.index(b) + len(b), text.index(e)
open(doc, "w").write(text[:i] + "\n" + body + "\n" + text[j:])
PY
}

# study NAME STUDY_FILE TABLES: runs the study, then the block shows the
# command and the chosen tables of its results.md ("ate", "ate speed").
study() {
  local name=$1 file=$2 tables=$3 dir="$OUT/$1"
  run "$DSLAM" ablate "$file" --out "$dir" --jobs "$JOBS" --resume || true  # failed cells are reported in the table
  [ "$DRY" = 1 ] && return 0
  python3 - "$dir/results.md" "$dir/results.json" "$file" "$tables" "$JOBS" > "$OUT/$name.block" <<'PY'
import json, sys
md, js, study, tables, jobs = open(sys.argv[1]).read(), json.load(open(sys.argv[2])), sys.argv[3], sys.argv[4].split(), sys.argv[5]
def table(title):
    lines = md.split("\n")
    start = next(i for i, l in enumerate(lines) if l.startswith("## " + title))
    out, seen = [], False
    for l in lines[start + 1:]:
        if l.startswith("|"):
            out.append(l); seen = True
        elif seen:
            break
    return "\n".join(out)
failed = sum(1 for r in js["runs"] if r["status"] != "ok")
print(f"    dslam ablate {study} --out OUT --jobs {jobs}\n")
print(f"Produced by {js['tool']}: {js['finished']} of {js['planned']} runs" + (f", {failed} failed" if failed else "") +
      f" ({js['evaluation']['align']} alignment; median over runs).\n")
titles = {"ate": "ATE RMSE", "speed": "Tracking, speed and memory"}
print("\n\n".join(table(titles[t]) for t in tables))
PY
  replace_block "$name" "$OUT/$name.block"
}

kitti() {
  local kd="$DSLAM_SHARED_DIR/data/kitti-stereo-51" dir="$OUT/kitti"
  run "$DSLAM" run config/pipelines/orbslam_baseline_stereo.yaml --dataset "$kd" --out "$dir" --no-progress > /dev/null
  for a in se3 sim3; do
    run "$DSLAM" eval ate "$kd/poses.txt" "$dir/trajectory.txt" --align $a --json > "$OUT/kitti_$a.json"
  done
  # Cross-check with an independent evaluator (numpy only, no dslam code).
  local py=""
  for p in python3 /usr/bin/python3; do
    if "$p" -c "import numpy" 2> /dev/null; then py=$p; break; fi
  done
  [ -n "$py" ] || { echo "results.sh: kitti needs python3 with numpy (apt-get install python3-numpy)" >&2; exit 1; }
  run "$py" scripts/independent/umeyama_ate.py "$kd/poses.txt" "$dir/trajectory.txt" > "$OUT/kitti_indep.txt"
  [ "$DRY" = 1 ] && return 0
  python3 - "$OUT" "$dir/summary.json" "$VERSION" > "$OUT/kitti.block" <<'PY'
import json, re, sys
out, summ, version = sys.argv[1], json.load(open(sys.argv[2])), sys.argv[3]
se3, sim3 = (json.load(open(f"{out}/kitti_{a}.json")) for a in ("se3", "sim3"))
ind = open(f"{out}/kitti_indep.txt").read()
def indep(name):
    m = re.search(name + r": (\d+) pairs, rmse ([0-9.]+) m, max ([0-9.]+) m, scale ([0-9.]+)", ind)
    return m.groups()
lengths = re.search(r"ground truth ([0-9.]+) m, estimate ([0-9.]+) m", ind).groups()
print("    dslam run config/pipelines/orbslam_baseline_stereo.yaml --dataset ../shared/data/kitti-stereo-51 --out OUT")
print("    dslam eval ate ../shared/data/kitti-stereo-51/poses.txt OUT/trajectory.txt --align se3")
print("    dslam eval ate ../shared/data/kitti-stereo-51/poses.txt OUT/trajectory.txt --align sim3")
print("    scripts/independent/umeyama_ate.py ../shared/data/kitti-stereo-51/poses.txt OUT/trajectory.txt\n")
print(f"Produced by {version}: {summ['tracked']}/{summ['frames']} frames tracked; path length {lengths[1]} m "
      f"estimated, {lengths[0]} m in poses.txt.\n")
print("| alignment | `dslam eval ate` RMSE | max | scale | independent (numpy Umeyama) RMSE | max | scale |")
print("|---|---|---|---|---|---|---|")
for name, key, r in (("SE(3)", "se3", se3), ("Sim(3)", "sim3", sim3)):
    _, rmse, mx, sc = indep(key)
    print(f"| {name} | {r['rmse']:.3f} m | {r['max']:.3f} m | {r['scale']:.3f} | {float(rmse):.3f} m | {float(mx):.3f} m | {float(sc):.3f} |")
PY
  replace_block kitti "$OUT/kitti.block"
}

# speed: config/studies/speed.yaml one run at a time (timing), the table of
# scripts/bench_speed.py (frames/s, tracking ms, worst frame, local BA, memory).
speed() {
  local dir="$OUT/speed"
  run "$DSLAM" ablate config/studies/speed.yaml --out "$dir" --jobs 1 --resume || true
  [ "$DRY" = 1 ] && return 0
  {
    echo "    scripts/bench_speed.sh OUT   # dslam ablate config/studies/speed.yaml --out OUT --jobs 1; scripts/bench_speed.py OUT"
    echo
    echo "Produced by $VERSION: 5 runs of each pipeline, one at a time; median (min-max) over the runs."
    echo
    python3 scripts/bench_speed.py "$dir" | sed 's/ | frames\/s \/ reference |$/ |/; s/ | [0-9.na]* |$/ |/; s/^|---|---|---|---|---|---|---|---|---|---|$/|---|---|---|---|---|---|---|---|---|/'
  } > "$OUT/speed.block"
  replace_block speed "$OUT/speed.block"
}

for s in "${SECTIONS[@]}"; do
  echo "== $s ($VERSION)" >&2
  case "$s" in
    matrix) study matrix config/studies/dynamic_matrix.yaml "ate speed" ;;
    ablation) study ablation config/studies/afc_repopulation.yaml "ate speed" ;;
    static) study static config/studies/static_scenes.yaml "ate speed" ;;
    speed) speed ;;
    kitti) kitti ;;
  esac
done
[ "$DRY" = 1 ] || echo "docs/results.md updated: ${SECTIONS[*]} (runs in $OUT)" >&2
