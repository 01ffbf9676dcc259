#!/usr/bin/env bash
# Installs dslam's build and test dependencies from Debian 12 packages.
# Non-interactive and idempotent: packages already installed are skipped,
# apt is not touched at all when nothing is missing.
set -euo pipefail

PKGS=(
  build-essential cmake ninja-build ccache pkg-config git
  libeigen3-dev libopencv-dev libsuitesparse-dev libceres-dev
  libmrpt-dev mrpt-apps liboctomap-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev nlohmann-json3-dev libdeflate-dev
  python3 python3-matplotlib python3-numpy
  parallel
)

missing=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PKGS[@]} packages already installed"
  exit 0
fi

echo "install_deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install_deps: done"
