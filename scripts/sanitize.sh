#!/usr/bin/env bash
# Sanitizer builds of dslam (issue 11):
#   scripts/sanitize.sh asan [ctest args...]  ASan + UBSan build in build-asan, runs the tests
#                                            (default: every test except the long scene runs,
#                                            see ASAN_EXCLUDE below)
#   scripts/sanitize.sh tsan                 TSan build in build-tsan, runs parallel-mode
#                                            pipelines (detector threads, local mapping, loop
#                                            closing, map merge after a tracking loss,
#                                            persistence filters) on short rendered scenes
# Any sanitizer report fails the run (halt_on_error / exitcode). Needs the shared folder.
set -euo pipefail
cd "$(dirname "$0")/.."
what="${1:-asan}"; shift || true
export DSLAM_SHARED_DIR="${DSLAM_SHARED_DIR:-$(cd .. && pwd)/shared}"
JOBS="${DSLAM_JOBS:-$(nproc)}"
# Long end-to-end scene tests: covered by the tsan part and the normal suite.
ASAN_EXCLUDE="${ASAN_EXCLUDE:-LoopClosing.LoopScenario|DynamicPipelines|SlamE2E.*Walking}"

case "$what" in
asan)
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDSLAM_BUILD_BENCHMARKS=OFF \
    -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined" \
    -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined"
  cmake --build build-asan -j "$JOBS"
  # detect_leaks=0: MRPT/OpenCV keep static singletons alive at exit.
  # allocator_may_return_null=1: a hostile rawlog makes MRPT's deserialiser ask
  # for a size read from the file (tests/fuzz/README.md F9); the request fails
  # and dslam reports a DataError, as in a normal build, instead of ASan aborting.
  export ASAN_OPTIONS="detect_leaks=0:abort_on_error=1:strict_string_checks=1:allocator_may_return_null=1"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
  ctest --test-dir build-asan --output-on-failure -j "${DSLAM_TEST_JOBS:-2}" --timeout 2400 -E "$ASAN_EXCLUDE" "$@"
  ;;
tsan)
  cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDSLAM_BUILD_TESTS=OFF -DDSLAM_BUILD_BENCHMARKS=OFF \
    -DCMAKE_CXX_FLAGS="-fsanitize=thread" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" \
    -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=thread"
  cmake --build build-tsan -j "$JOBS" --target dslam
  export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:exitcode=66:suppressions=$PWD/scripts/tsan.supp"
  # OpenCV's thread pool is not instrumented: its loop bodies are suppressed
  # (scripts/tsan.supp); dslam's own threads stay checked.
  B=build-tsan/bin/dslam
  W="${TMPDIR:-/tmp}/dslam-tsan"
  mkdir -p "$W"
  # Scenes are rendered by the normal build when there is one (the renderer
  # under TSan runs at ~1 frame/s); the pipelines run under TSan.
  R=build/bin/dslam
  [ -x "$R" ] || R=$B
  render() {  # scenario frames -> folder (rendered once)
    [ -f "$W/$1_$2/groundtruth.txt" ] ||
      $R synth "config/scenarios/$1.yaml" --out "$W/$1_$2" --frames "$2" --resolution 320x240 --overwrite >/dev/null
    echo "$W/$1_$2"
  }
  run() {  # name pipeline dataset
    echo "== tsan: $1"
    DSLAM_MODE=parallel $B run "config/pipelines/$2" --dataset "$3" --out "$W/out_$1" --no-progress \
      >"$W/$1.log" 2>&1 || { tail -80 "$W/$1.log"; echo "tsan: $1 FAILED (log: $W/$1.log)"; exit 1; }
    grep -E "^frames:|^ATE" "$W/$1.log"
  }
  WX=$(render walking_xyz 150)
  run crowd_slam crowd_slam.yaml "$WX"                        # real Yolo-Fastest on a detector thread
  run changing_slam_dynamic changing_slam_dynamic.yaml "$WX"  # detector thread + EKF classifier
  run baseline_parallel orbslam_baseline.yaml "$WX"           # local mapping thread
  run loop_parallel orbslam_baseline.yaml "$(render loop 1000)"  # loop closing thread + global BA
  # lights out: tracking lost, a new map, merged back; persistence filters on the mapping thread
  run changing_dark synthetic/changing_slam.yaml "$(render shift_dark 570)"
  echo "tsan: clean"
  ;;
*)
  echo "usage: $0 asan|tsan" >&2; exit 2 ;;
esac
