#!/usr/bin/env bash
# Installs every Debian package hyperqn needs to build, run, test and post-process.
# Idempotent: packages already present are skipped, so a second run costs a second.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  petsc-dev libmetis-dev libopenmpi-dev openmpi-bin
  libhdf5-openmpi-dev libeigen3-dev libyaml-cpp-dev libsuitesparse-dev
  libopenblas0-serial
  python3 python3-numpy python3-matplotlib python3-h5py python3-meshio python3-yaml python3-pytest
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
