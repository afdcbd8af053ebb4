#!/usr/bin/env bash
# Configures and builds the project (Release) into ./build with two jobs.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE:-Release} "$@"
cmake --build "$BUILD_DIR" -j"${JOBS:-2}"
