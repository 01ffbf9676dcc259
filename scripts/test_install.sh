#!/usr/bin/env bash
# The install-and-examples step of CI (docs/embedding.md): installs the build
# to a temporary prefix, checks that every installed header compiles on its
# own against the prefix alone, then copies examples/ out of the source tree,
# builds each example against the prefix (find_package(dslam)) and runs it.
#
#   scripts/test_install.sh [BUILD_DIR]      (default build; needs a finished build)
#
# DSLAM_INSTALL_TEST_KEEP=1 keeps the temporary folder. Prints the build time
# of every example.
set -euo pipefail
cd "$(dirname "$0")/.."
SRC=$(pwd)
BUILD=${1:-build}
JOBS=${DSLAM_JOBS:-2}
TMP=$(mktemp -d /tmp/dslam_install_test.XXXXXX)
cleanup() { if [ "${DSLAM_INSTALL_TEST_KEEP:-0}" != 1 ]; then rm -rf "$TMP"; else echo "kept $TMP"; fi; }
trap cleanup EXIT
P=$TMP/prefix
LAUNCHER=()
if command -v ccache > /dev/null; then LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
step() { echo "== $*"; }
fail() { echo "test_install: FAILED: $*" >&2; exit 1; }
now() { date +%s.%N; }
secs() { python3 -c "print(f'{$2 - $1:.1f}')"; }

step "install to $P"
cmake --install "$BUILD" --prefix "$P" > "$TMP/install.log"
for f in bin/dslam lib/cmake/dslam/dslamConfig.cmake lib/cmake/dslam/dslamConfigVersion.cmake \
         share/dslam/orb_k10l5.dvoc.gz share/dslam/config/pipelines/orbslam_baseline.yaml \
         share/dslam/plot_trajectory.py share/dslam/plot_study.py include/dslam/slam/system.h; do
  [ -e "$P/$f" ] || fail "not installed: $f"
done
# Nothing installed may point back into the source or build tree.
if grep -rl -e "$SRC/modules" -e "$SRC/plugins" -e "$(cd "$BUILD" && pwd)" "$P/lib/cmake" "$P/include" > "$TMP/leaks" 2>/dev/null; then
  cat "$TMP/leaks"; fail "installed files refer to the source or build tree"
fi
if ldd "$P/bin/dslam" | grep -q "$(cd "$BUILD" && pwd)"; then fail "the installed dslam loads libraries from the build tree"; fi
"$P/bin/dslam" --version

step "installed headers: each one's includes resolve in the prefix; together they compile"
t0=$(now)
cmake -S "$SRC/tests/install/header_check" -B "$TMP/header_check" -G Ninja -DCMAKE_PREFIX_PATH="$P" \
  "${LAUNCHER[@]}" > "$TMP/header_check.log" 2>&1 || { cat "$TMP/header_check.log"; fail "header check: configure"; }
cmake --build "$TMP/header_check" -j "$JOBS" >> "$TMP/header_check.log" 2>&1 || {
  grep -B2 -A8 "error" "$TMP/header_check.log" | head -60; fail "an installed header does not preprocess or compile against the prefix"; }
echo "   $(ls "$TMP"/header_check/tu/*.cpp | wc -l) headers, $(secs "$t0" "$(now)") s"

step "examples, copied out of the source tree"
cp -r "$SRC/examples" "$TMP/examples"
for ex in evaluate detect_and_track embed_system my_classifier_plugin; do
  t0=$(now)
  cmake -S "$TMP/examples/$ex" -B "$TMP/build_$ex" -G Ninja -DCMAKE_PREFIX_PATH="$P" "${LAUNCHER[@]}" \
    > "$TMP/$ex.log" 2>&1 || { cat "$TMP/$ex.log"; fail "$ex: configure"; }
  cmake --build "$TMP/build_$ex" -j "$JOBS" >> "$TMP/$ex.log" 2>&1 || { cat "$TMP/$ex.log"; fail "$ex: build"; }
  echo "   $ex: configured and built in $(secs "$t0" "$(now)") s"
done

# Everything below runs the installed dslam and the examples in $TMP.
cd "$TMP"
export PATH="$P/bin:$PATH"
step "a small scene (installed dslam synth)"
dslam synth "$P/share/dslam/config/scenarios/walking_xyz.yaml" --out "$TMP/wx" --frames 60 --resolution 320x240 \
  --no-right > /dev/null
dslam run "$P/share/dslam/config/pipelines/orbslam_baseline.yaml" --dataset "$TMP/wx" --out "$TMP/run_base" \
  --no-progress > "$TMP/run_base.log" 2>&1 || { cat "$TMP/run_base.log"; fail "installed dslam run"; }

step "evaluate"
"$TMP/build_evaluate/evaluate" "$TMP/wx/groundtruth.txt" "$TMP/run_base/trajectory.txt" | tee "$TMP/evaluate.out"
ours=$(sed -n 's/^ATE  (se3): rmse \([0-9.]*\) m.*/\1/p' "$TMP/evaluate.out")
cli=$(dslam eval ate "$TMP/wx/groundtruth.txt" "$TMP/run_base/trajectory.txt" --json | python3 -c 'import json,sys; print("%.4f" % json.load(sys.stdin)["rmse"])')
[ -n "$ours" ] && [ "$ours" = "$cli" ] || fail "evaluate gives ATE '$ours', dslam eval ate gives '$cli'"
grep -q "^RPE " "$TMP/evaluate.out" || fail "evaluate printed no RPE"

step "detect_and_track"
"$TMP/build_detect_and_track/detect_and_track" "$TMP/wx" > "$TMP/detect.out" || { tail "$TMP/detect.out"; fail detect_and_track; }
head -2 "$TMP/detect.out"; grep -A40 "^objects (id" "$TMP/detect.out"
grep -q "^objects that move:.*(person)" "$TMP/detect.out" || fail "detect_and_track did not find the walking people of walking_xyz"

step "embed_system"
"$TMP/build_embed_system/embed_system" --frames 60 > "$TMP/embed.out" || { tail "$TMP/embed.out"; fail embed_system; }
head -3 "$TMP/embed.out"; tail -1 "$TMP/embed.out"
[ "$(grep -c '^frame ' "$TMP/embed.out")" = 60 ] || fail "embed_system did not print a pose per frame"
python3 - "$TMP/embed.out" <<'PY' || fail "embed_system: tracking or ATE out of range"
import re, sys
m = re.search(r"tracked (\d+) of (\d+) frames.*ATE ([0-9.]+) m", open(sys.argv[1]).read())
assert m and int(m.group(1)) >= 55 and float(m.group(3)) < 0.05, m and m.groups()
PY

step "my_classifier_plugin (loaded by the installed dslam through plugin_dirs)"
[ -f "$TMP/build_my_classifier_plugin/plugins/libmy_classifier.so" ] || fail "plugin library not built"
# (the listing is captured first: with pipefail, grep -q closing the pipe early
# would fail the pipeline once the listing outgrows the pipe buffer)
listing=$(DSLAM_PLUGIN_PATH="$TMP/build_my_classifier_plugin/plugins" dslam plugins) || fail "dslam plugins failed"
grep -q "my::BorderFilter" <<< "$listing" || fail "dslam plugins does not list my::BorderFilter"
dslam run "$TMP/build_my_classifier_plugin/my_pipeline.yaml" --dataset "$TMP/wx" --out "$TMP/run_plugin" \
  --no-progress > "$TMP/run_plugin.log" 2>&1 || { cat "$TMP/run_plugin.log"; fail "dslam run with the plug-in"; }
grep -q "my::BorderFilter" "$TMP/run_plugin/config.resolved.yaml" || fail "the run did not use the plug-in"
python3 - "$TMP/run_plugin/frames.csv" <<'PY' || fail "the plug-in marked no keypoint dynamic"
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
dropped = sum(int(r["keypoints"]) - int(r["usable_keypoints"]) for r in rows)
assert len(rows) == 60 and dropped > 60 * 50, (len(rows), dropped)
print(f"   BorderFilter dropped {dropped} keypoints over {len(rows)} frames")
PY
echo "test_install: all passed"
