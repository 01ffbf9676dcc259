#!/usr/bin/env bash
# Speed benchmark (issue 13): runs config/studies/speed.yaml (5 runs of each
# pipeline, one at a time) with `dslam ablate`, then prints per variant and
# dataset the median and range of wall frames/s, the tracking time per frame,
# the worst frame, the largest local BA, peak memory and the ratio of the
# frames/s to a saved reference run of the same machine.
#
#   scripts/bench_speed.sh [OUT] [--study FILE] [--save-reference]
#
# The reference is $DSLAM_SPEED_REFERENCE (default ~/.cache/dslam/speed_reference.csv);
# --save-reference makes this run the reference. Run it on an idle machine.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=out/bench_speed
STUDY=config/studies/speed.yaml
SAVE=0
while [ $# -gt 0 ]; do
  case "$1" in
    --study) STUDY="$2"; shift 2 ;;
    --save-reference) SAVE=1; shift ;;
    -h|--help) sed -n 2,12p "$0"; exit 0 ;;
    *) OUT="$1"; shift ;;
  esac
done
DSLAM="${DSLAM_EXE:-build/bin/dslam}"
[ -x "$DSLAM" ] || { echo "error: $DSLAM not found: build first (scripts/build.sh)" >&2; exit 1; }
export DSLAM_SHARED_DIR="${DSLAM_SHARED_DIR:-$(cd .. && pwd)/shared}"
REF="${DSLAM_SPEED_REFERENCE:-$HOME/.cache/dslam/speed_reference.csv}"
"$DSLAM" ablate "$STUDY" --out "$OUT" --jobs 1 --resume
ARGS=(--reference "$REF" --save "$OUT/speed.csv")
python3 scripts/bench_speed.py "$OUT" "${ARGS[@]}"
if [ "$SAVE" = 1 ]; then
  mkdir -p "$(dirname "$REF")"
  cp "$OUT/speed.csv" "$REF"
  echo "reference saved to $REF"
fi
