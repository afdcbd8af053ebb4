#!/usr/bin/env bash
# Configures and builds the project (Release) into ./build with two jobs, then prints the wall time.
# Extra arguments go to the configure step, e.g. -DPRIORSLAM_UNITY_BUILD=OFF (file by file; see doc/conventions.md).
# Env: BUILD_DIR (default build), JOBS (default 2), CMAKE_BUILD_TYPE (default Release).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
start=$(date +%s)
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE:-Release} "$@"
cmake --build "$BUILD_DIR" -j"${JOBS:-2}"
echo "build.sh: configured and built $BUILD_DIR in $(( $(date +%s) - start )) s"
