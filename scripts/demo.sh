#!/usr/bin/env bash
# The main job on built-in data, from a fresh clone: install the Debian packages, build, render a synthetic
# sequence with full ground truth, run monocular SLAM on it, and evaluate the trajectory against ground truth
# (metrics on stdout, JSON and PNG plots in the output folder).
#
#   bash scripts/demo.sh [OUT_DIR]          (default OUT_DIR: ./out/demo)
#
# Environment: SKIP_INSTALL=1 skips apt, SKIP_BUILD=1 reuses ./build, SCENARIO (default room), FRAMES (default 300).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/demo}
SCENARIO=${SCENARIO:-room}
FRAMES=${FRAMES:-300}
SEED=${SEED:-1}
BIN=${BUILD_DIR:-build}/bin

[ "${SKIP_INSTALL:-0}" = 1 ] || bash scripts/install-deps.sh
[ "${SKIP_BUILD:-0}" = 1 ] || bash scripts/build.sh
mkdir -p "$OUT"

echo "== 1/3 render the synthetic '$SCENARIO' sequence ($FRAMES frames, seed $SEED)"
"$BIN/slam-synth" --scenario "$SCENARIO" --frames "$FRAMES" --seed "$SEED" --out "$OUT/data"

echo "== 2/3 monocular SLAM (sequential, deterministic)"
"$BIN/slam-run" --config config/slam/synthetic.ini --rawlog "$OUT/data/$SCENARIO.rawlog" --out "$OUT/run" --seed "$SEED"

echo "== 3/3 evaluation against ground truth (Sim(3) alignment)"
"$BIN/slam-eval" "$OUT/data/${SCENARIO}_groundtruth.txt" "$OUT/run/trajectory.txt" --align sim3 \
  --json "$OUT/eval.json" --plot-dir "$OUT/plots"

echo
echo "Outputs in $OUT: data/ (rawlog + ground truth), run/ (trajectory.txt, keyframes.txt, map.slammap, report.json),"
echo "eval.json and plots/*.png"
