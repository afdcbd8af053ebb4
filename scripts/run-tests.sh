#!/usr/bin/env bash
# Installs the Debian packages, builds, and runs every test (unit, data, e2e).
# Tests that need ../shared/data skip with a message when it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh -DPRIORSLAM_PYTHON=ON  # the Python module and its pytest suite are part of the tests
ctest --test-dir "${BUILD_DIR:-build}" --output-on-failure -j2
