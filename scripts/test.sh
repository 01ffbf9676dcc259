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
scripts/build.sh
ctest --test-dir build --output-on-failure -j "${DSLAM_TEST_JOBS:-2}" --timeout 900
# dslam as an installed package: install to a temporary prefix, check the
# installed headers, build and run examples/ against it (docs/embedding.md).
scripts/test_install.sh build
