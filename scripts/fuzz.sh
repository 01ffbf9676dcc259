#!/usr/bin/env bash
# libFuzzer runs of the harnesses in tests/fuzz (tests/fuzz/README.md).
#
#   scripts/fuzz.sh build                 clang build of the fuzzers into ./build-fuzz
#   scripts/fuzz.sh seeds                 seed corpora into build-fuzz/seeds/<target>
#   scripts/fuzz.sh run TARGET [SECONDS]  fuzz one target (default 600 s) from its seeds and
#                                         committed corpus; log in build-fuzz/logs/TARGET.log
#   scripts/fuzz.sh merge TARGET          minimise everything found into tests/fuzz/corpus/TARGET
#                                         (inputs <= MERGE_MAX bytes, default 4096: the regression corpus)
#   scripts/fuzz.sh all [SECONDS]         run + merge every target, one after the other
#
# One fuzzer at a time, niced, with the limits the project holds itself to:
# no input may take > 10 s, > 2 GB RSS or a single > 1 GB allocation (rawlog:
# see extra() below).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
BF=$ROOT/build-fuzz
SHARED=${DSLAM_SHARED_DIR:-$ROOT/../shared}
TARGETS="pipeline camera_yaml scenario trajectory dataset_lists labels vocabulary atlas rawlog"
export ASAN_OPTIONS=${ASAN_OPTIONS:-allocator_may_return_null=0:detect_leaks=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# Per-target options. rawlog: MRPT's deserialisation allocates every string /
# vector with the length read from the file before reading its data (up to
# 4 GiB for a string; the zero-fill alone can outlast -timeout under ASan).
# That is MRPT's and is documented in tests/fuzz/README.md. The rawlog
# fuzzer therefore runs in fork mode (one worker) and goes on past OOMs and
# timeouts (their inputs are still written to artifacts/ to be checked);
# crashes and sanitizer reports stop it as for every target.
limits() { echo "-rss_limit_mb=2048 -malloc_limit_mb=1024"; }
# It also goes on past crashes (-ignore_crashes=1): MRPT writes through a null
# pointer when the allocation of a range image of the size in the file fails
# (tests/fuzz/known/). Every crash-* artifact must then be triaged by hand
# (scripts/fuzz.sh triage rawlog lists the top dslam frame of each).
extra() { case $1 in rawlog) echo "-fork=1 -ignore_ooms=1 -ignore_timeouts=1 -ignore_crashes=1" ;; esac; }
# (rawlog: an image size from the file reaches OpenCV's malloc inside MRPT; a
# failed malloc is a clean error there, so ASan may return NULL.)
asan() { case $1 in rawlog) echo "allocator_may_return_null=1:detect_leaks=0" ;; *) echo "$ASAN_OPTIONS" ;; esac; }

maxlen() { case $1 in rawlog|atlas|vocabulary) echo 8192 ;; *) echo 4096 ;; esac; }

build() {
  CC=clang CXX=clang++ cmake -S . -B "$BF" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE=-O1 \
    -DDSLAM_BUILD_FUZZERS=ON -DDSLAM_BUILD_TESTS=OFF -DDSLAM_BUILD_BENCHMARKS=OFF
  local t all=fuzz_make_seeds
  for t in $TARGETS; do all="$all fuzz_$t"; done
  nice -n 19 cmake --build "$BF" -j "${DSLAM_JOBS:-2}" --target $all
}

# prefix SELECTOR_BYTE FILE OUT: OUT = the byte + FILE (selector harnesses)
prefix() { { printf "\\x$(printf %02x "$1")"; cat "$2"; } > "$3"; }

seeds() {
  local S=$BF/seeds t f n
  rm -rf "$S" && mkdir -p "$S"
  if [ -x "$BF/tests/fuzz/fuzz_make_seeds" ]; then
    "$BF/tests/fuzz/fuzz_make_seeds" "$S"
  else
    echo "warning: $BF/tests/fuzz/fuzz_make_seeds not built: no synthetic seeds (vocabulary, atlas, rawlog, labels)" >&2
  fi
  for t in $TARGETS; do mkdir -p "$S/$t"; done
  for f in config/pipelines/*.yaml config/pipelines/synthetic/*.yaml; do cp "$f" "$S/pipeline/$(basename "$(dirname "$f")")_$(basename "$f")"; done
  cp config/cameras/*.yaml "$S/camera_yaml/"
  for f in config/scenarios/*.yaml config/scenarios/common/*.yaml; do cp "$f" "$S/scenario/$(basename "$f")"; done
  local T=$S/.tmp && mkdir -p "$T"
  # Trajectories (selector: 0 auto, 1 TUM, 2 TUM unsorted, 3 KITTI, 4 KITTI + times, 5 EuRoC, 6 auto .csv).
  head -n 12 "$SHARED/data/tum-meta/groundtruth/fr1_xyz.txt" > "$T/tum"
  head -n 4 "$SHARED/data/kitti-stereo-51/poses.txt" > "$T/kitti"
  { cat "$T/kitti"; printf '\0'; printf '0.0\n0.1\n0.2\n0.3\n'; } > "$T/kitti_times"
  printf '#timestamp,p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []\n1403715273262142976,0.878,2.142,0.947,0.060,-0.828,-0.058,-0.553\n1403715273267142912,0.879,2.142,0.947,0.060,-0.828,-0.058,-0.553\n' > "$T/euroc"
  for n in 0 1 2; do prefix $n "$T/tum" "$S/trajectory/tum_$n"; done
  prefix 3 "$T/kitti" "$S/trajectory/kitti"
  prefix 4 "$T/kitti_times" "$S/trajectory/kitti_times"
  prefix 5 "$T/euroc" "$S/trajectory/euroc"
  prefix 6 "$T/euroc" "$S/trajectory/euroc_auto"
  # Dataset lists (0 rgb.txt, 1 associations.txt, 2 KITTI calib.txt, 3 EuRoC data.csv, 4 EuRoC sensor.yaml).
  head -n 8 "$SHARED/data/tum-meta/associations/fr3_walking_xyz.txt" > "$T/assoc"
  { echo '# color images'; awk '{print $1, $2}' "$T/assoc"; } > "$T/rgb"
  prefix 0 "$T/rgb" "$S/dataset_lists/rgb"
  prefix 1 "$T/assoc" "$S/dataset_lists/assoc"
  prefix 2 "$SHARED/data/kitti-stereo-51/calib.txt" "$S/dataset_lists/calib"
  head -n 6 "$SHARED/data/euroc-v101-micro/mav0/cam0/data.csv" > "$T/csv"
  prefix 3 "$T/csv" "$S/dataset_lists/euroc_csv"
  prefix 4 "$SHARED/data/euroc-v101-micro/mav0/cam0/sensor.yaml" "$S/dataset_lists/euroc_sensor"
  # Vocabulary and rawlog fragments of the shared files (truncated: the loaders' early paths).
  zcat "$SHARED/data/vocab/dbow2_k9l3_kimera.yml.gz" | head -c 3000 > "$T/voc_yml" || true
  prefix 3 "$T/voc_yml" "$S/vocabulary/shared_dbow2_head"
  zcat "$SHARED/data/mrpt/tests_rgbd.rawlog" | head -c 8000 > "$S/rawlog/shared_rgbd_head" || true
  rm -rf "$T"
  for t in $TARGETS; do echo "$t: $(ls "$S/$t" | wc -l) seeds"; done
}

run() {
  local t=$1 secs=${2:-600}
  mkdir -p "$BF/logs" "$BF/found/$t" "$BF/artifacts/$t" "tests/fuzz/corpus/$t"
  ( cd "$BF/artifacts/$t" && ASAN_OPTIONS=$(asan "$t") nice -n 19 "$BF/tests/fuzz/fuzz_$t" -max_total_time="$secs" -timeout=10 \
      $(limits "$t") $(extra "$t") -max_len="$(maxlen "$t")" \
      -print_final_stats=1 -artifact_prefix="$BF/artifacts/$t/" \
      "$BF/found/$t" "$BF/seeds/$t" "$ROOT/tests/fuzz/corpus/$t" ) > "$BF/logs/$t.log" 2>&1 || true
  grep -E 'stat::number_of_executed_units|Done [0-9]+ runs|cov:' "$BF/logs/$t.log" | tail -n 3
  ls "$BF/artifacts/$t" | grep -E '^(crash|leak|timeout|oom|slow-unit)-' || echo "$t: no artifacts"
}

merge() {
  local t=$1 M=$BF/merged/$1
  rm -rf "$M" && mkdir -p "$M" "$BF/small/$t"
  rm -rf "$BF/small/$t"/*
  # Only small inputs (<= MERGE_MAX bytes, default 4 KB) are candidates for the committed corpus.
  find "$BF/found/$t" "$BF/seeds/$t" "tests/fuzz/corpus/$t" -maxdepth 1 -type f -size -"$((${MERGE_MAX:-4096} + 1))"c \
    -exec cp -t "$BF/small/$t" {} + 2>/dev/null || true
  ASAN_OPTIONS=$(asan "$t") nice -n 19 "$BF/tests/fuzz/fuzz_$t" -merge=1 -timeout=10 $(limits "$t") \
    -max_len="$(maxlen "$t")" "$M" "$BF/small/$t" > "$BF/logs/$t.merge.log" 2>&1
  # Keep the named regression inputs of findings (finding_*), replace the rest.
  find "tests/fuzz/corpus/$t" -maxdepth 1 -type f ! -name 'finding_*' -delete
  cp "$M"/* "tests/fuzz/corpus/$t/"
  echo "$t: $(ls "tests/fuzz/corpus/$t" | wc -l) files, $(cat "tests/fuzz/corpus/$t"/* | wc -c) bytes"
}

# triage TARGET: for each crash artifact, the first stack frame in dslam code
# (or "third-party only").
triage() {
  local t=$1 f
  for f in "$BF/artifacts/$t"/crash-*; do
    [ -e "$f" ] || continue
    echo "== $(basename "$f"): $( (ASAN_OPTIONS=$(asan "$t") "$BF/tests/fuzz/fuzz_$t" "$f" 2>&1 || true) |
      grep -E '^ +#[0-9]+ 0x[0-9a-f]+ in ' | grep -E ' in dslam::| /work/| \.\./(modules|plugins)/' | grep -v 'fuzz_common.h\|fuzz_'"$t"'.cpp' |
      head -n 1 | sed 's/^ *//' || true)"
  done
}

case ${1:-} in
  build) build ;;
  seeds) seeds ;;
  run) run "$2" "${3:-600}" ;;
  merge) merge "$2" ;;
  triage) triage "$2" ;;
  all) for t in $TARGETS; do run "$t" "${2:-600}"; merge "$t"; done ;;
  *) sed -n '2,15p' "$0"; exit 2 ;;
esac
