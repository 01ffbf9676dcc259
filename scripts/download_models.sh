#!/usr/bin/env bash
# Downloads the detector models used by dslam's detector plugins from their
# public upstream locations into DIR, in the layout dslam expects under
# ${DSLAM_SHARED_DIR}/models:
#
#   DIR/yolo-fastest-body/  yolo-fastest-1.1_body.cfg/.weights, body.names
#   DIR/yolo-fastest-coco/  yolo-fastest-1.1(.-xl).cfg/.weights, coco.names
#   DIR/yolox-nano/         yolox_nano.onnx, coco.names, LICENSE
#   DIR/enet-cityscapes/    enet-model.net, enet-classes.txt, enet-colors.txt
#
# Usage: scripts/download_models.sh DIR [--force]
# Then either point DSLAM_SHARED_DIR at DIR's parent (DIR must be named
# "models"), or set the plugins' model paths (cfg/weights/model/labels).
# Never run by the build or the tests. Needs curl or wget.
#
# Sources (licences):
#   Yolo-Fastest 1.1   https://github.com/dog-qiuqiu/Yolo-Fastest (ModelZoo/)   YOLO licence (public domain)
#   COCO names         https://github.com/pjreddie/darknet (data/coco.names)     public domain
#   YOLOX-nano ONNX    https://github.com/opencv/opencv_zoo (models/object_detection_yolox)  Apache-2.0
#   ENet Cityscapes    https://github.com/e-lab/ENet-training, Torch export from
#                      https://github.com/ishacusp/ARGO_Labs (opencv-semantic-segmentation)  BSD-3
set -euo pipefail

usage() { echo "usage: $0 DIR [--force]" >&2; exit 2; }
[ $# -ge 1 ] || usage
DIR=$1
FORCE=0
[ "${2:-}" = "--force" ] && FORCE=1
[ $# -le 2 ] || usage

YF=https://raw.githubusercontent.com/dog-qiuqiu/Yolo-Fastest/master/ModelZoo
DARKNET=https://raw.githubusercontent.com/pjreddie/darknet/master/data
# The commit of opencv_zoo that added yolox_nano.onnx (a Git LFS file).
ZOO_COMMIT=a029798ece28f2377c39f1a6f6b8ddea5b304195
ZOO=https://media.githubusercontent.com/media/opencv/opencv_zoo/$ZOO_COMMIT/models/object_detection_yolox
ZOO_RAW=https://raw.githubusercontent.com/opencv/opencv_zoo/$ZOO_COMMIT/models/object_detection_yolox
ENET=https://raw.githubusercontent.com/ishacusp/ARGO_Labs/master/opencv-semantic-segmentation/enet-cityscapes

fetch() {  # fetch URL DEST
  local url=$1 dest=$2
  if [ -s "$dest" ] && [ $FORCE = 0 ]; then
    echo "  have $dest"
    return
  fi
  mkdir -p "$(dirname "$dest")"
  echo "  get  $url"
  if command -v curl >/dev/null; then
    curl -fL --retry 3 -o "$dest.part" "$url"
  elif command -v wget >/dev/null; then
    wget -q -O "$dest.part" "$url"
  else
    echo "error: neither curl nor wget found" >&2
    exit 1
  fi
  if [ ! -s "$dest.part" ] || head -c 64 "$dest.part" | grep -q "git-lfs.github.com"; then
    echo "error: $url gave an empty file or a Git LFS pointer" >&2
    rm -f "$dest.part"
    exit 1
  fi
  mv "$dest.part" "$dest"
}

echo "Yolo-Fastest 1.1 body -> $DIR/yolo-fastest-body"
fetch "$YF/yolo-fastest-1.1_body/yolo-fastest-1.1_body.cfg" "$DIR/yolo-fastest-body/yolo-fastest-1.1_body.cfg"
fetch "$YF/yolo-fastest-1.1_body/yolo-fastest-1.1_body.weights" "$DIR/yolo-fastest-body/yolo-fastest-1.1_body.weights"
[ -s "$DIR/yolo-fastest-body/body.names" ] || echo body > "$DIR/yolo-fastest-body/body.names"

echo "Yolo-Fastest 1.1 / 1.1-xl COCO -> $DIR/yolo-fastest-coco"
for m in yolo-fastest-1.1 yolo-fastest-1.1-xl; do
  fetch "$YF/yolo-fastest-1.1_coco/$m.cfg" "$DIR/yolo-fastest-coco/$m.cfg"
  fetch "$YF/yolo-fastest-1.1_coco/$m.weights" "$DIR/yolo-fastest-coco/$m.weights"
done
fetch "$DARKNET/coco.names" "$DIR/yolo-fastest-coco/coco.names"

echo "YOLOX-nano ONNX -> $DIR/yolox-nano"
fetch "$ZOO/yolox_nano.onnx" "$DIR/yolox-nano/yolox_nano.onnx"
fetch "$ZOO_RAW/README.md" "$DIR/yolox-nano/README.md"
fetch "$ZOO_RAW/LICENSE" "$DIR/yolox-nano/LICENSE"
cp -n "$DIR/yolo-fastest-coco/coco.names" "$DIR/yolox-nano/coco.names" 2>/dev/null || true

echo "ENet Cityscapes -> $DIR/enet-cityscapes"
for f in enet-model.net enet-classes.txt enet-colors.txt; do
  fetch "$ENET/$f" "$DIR/enet-cityscapes/$f"
done

echo "done: $DIR"
