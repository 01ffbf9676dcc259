#!/usr/bin/env bash
# Regenerates the ORB vocabulary shipped with dslam
# (modules/place_recognition/data/orb_k10l5.dvoc.gz, docs/place_recognition.md).
#
# Training set (deterministic: fixed scenarios, seed and parameters):
#   - 30 evenly spaced frames rendered from each synthetic scenario in
#     config/scenarios (14 scenarios, their own seeds), 640x480;
#   - the real images of the shared data folder except the held-out
#     place-recognition test frames (data/tum-frames/loop-10):
#     KITTI left+right (102), EuRoC V1_01 cam0+cam1 (80), data/images (3),
#     data/tum-frames/rgbd-pair RGB (2; the 16-bit depth maps are skipped).
#   ORB: dslam's extractor, 1000 features per image. Tree: k=10, L=5,
#   tf-idf, L1, seed 0, 25 k-majority iterations per node.
#
# Usage: scripts/train_default_vocab.sh [OUT] [extra `dslam vocab train` options]
#   DSLAM_EXE        dslam executable (default: build/bin/dslam)
#   DSLAM_SHARED_DIR shared data folder (default: ../shared)
#   e.g. scripts/train_default_vocab.sh /tmp/orb_k10l4.dvoc --levels 4
# Takes ~2-3 minutes on two cores (rendering dominates).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
exe="${DSLAM_EXE:-$root/build/bin/dslam}"
shared="${DSLAM_SHARED_DIR:-$(cd "$root/.." && pwd)/shared}"
out="${1:-$root/modules/place_recognition/data/orb_k10l5.dvoc.gz}"
shift || true

if [ ! -x "$exe" ]; then
  echo "error: dslam executable not found: $exe (build it, or set DSLAM_EXE)" >&2
  exit 1
fi
data="$shared/data"
for d in kitti-stereo-51/image_l kitti-stereo-51/image_r euroc-v101-micro/mav0/cam0/data \
         euroc-v101-micro/mav0/cam1/data images tum-frames/rgbd-pair; do
  if [ ! -d "$data/$d" ]; then
    echo "error: shared data folder missing: $data/$d (set DSLAM_SHARED_DIR)" >&2
    exit 1
  fi
done

scenarios=(close_person crowd loop one_chair replacing shift sitting_xyz static_office
           unknown_object vanishing walking_halfsphere walking_rpy walking_static walking_xyz)
args=()
for s in "${scenarios[@]}"; do
  args+=(--scenario "$root/config/scenarios/$s.yaml")
done

"$exe" vocab train "${args[@]}" --scenario-frames 30 \
  --images "$data/kitti-stereo-51/image_l" --images "$data/kitti-stereo-51/image_r" \
  --images "$data/euroc-v101-micro/mav0/cam0/data" --images "$data/euroc-v101-micro/mav0/cam1/data" \
  --images "$data/images" --images "$data/tum-frames/rgbd-pair" \
  --features 1000 --k 10 --levels 5 --seed 0 --iterations 25 --weighting tf-idf --scoring l1 \
  --threads "${DSLAM_THREADS:-2}" --out "$out" "$@"
"$exe" vocab info "$out"
sha256sum "$out"
