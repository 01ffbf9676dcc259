#!/usr/bin/env bash
# The README's test command: installs what is missing, builds, runs the whole
# test suite. Needs the shared data folder (DSLAM_SHARED_DIR, default ../shared).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
export DSLAM_SHARED_DIR="${DSLAM_SHARED_DIR:-$(cd .. && pwd)/shared}"
if [ ! -d "$DSLAM_SHARED_DIR" ]; then
  echo "error: shared data folder not found: $DSLAM_SHARED_DIR (set DSLAM_SHARED_DIR)" >&2
  exit 1
fi
# The end-to-end tests render their synthetic scenes once into
# build/test_data (about 3.5 GB of PNG images; the build itself is about 0.1 GB).
need_mb=4000
free_mb=$(df -Pm . | awk 'NR==2 {print $4}')
have_mb=$(du -sm build/test_data 2>/dev/null | cut -f1 || true)
if [ -n "$free_mb" ] && [ $((free_mb + ${have_mb:-0})) -lt "$need_mb" ]; then
  echo "warning: $free_mb MB free on the disk of $(pwd); the test suite writes about $need_mb MB" \
       "(build/ and the rendered scenes in build/test_data): tests will fail with write errors if it fills up" >&2
fi
scripts/build.sh
ctest --test-dir build --output-on-failure -j "${DSLAM_TEST_JOBS:-2}" --timeout 900
# dslam as an installed package: install to a temporary prefix, check the
# installed headers, build and run examples/ against it (docs/embedding.md).
scripts/test_install.sh build
