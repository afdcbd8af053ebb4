#!/usr/bin/env bash
# Installs every Debian 12 package the project needs. Safe to run twice.
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
PKGS=(
  build-essential cmake pkg-config git ca-certificates
  libeigen3-dev
  libmrpt-dev mrpt-apps
  libopencv-dev libopencv-contrib-dev
  libceres-dev libsuitesparse-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  nlohmann-json3-dev libcli11-dev
  libyaml-cpp-dev
  # the Python module priorslam (python/, doc/python.md) and its tests; OpenCV and matplotlib for its examples
  python3-dev pybind11-dev python3-pybind11 python3-numpy python3-pytest python3-opencv python3-matplotlib
  # scripts/slurm-local.sh: private one-node Slurm cluster for tests
  slurmctld slurmd slurm-client munge
)
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${PKGS[@]}"
echo "install-deps: all packages present"
