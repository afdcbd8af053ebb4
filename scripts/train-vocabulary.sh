#!/usr/bin/env bash
# Trains the bag-of-words vocabulary of doc/places.md into out/places/orb_k16_l4.pvoc (2.2 MB: generated data, kept
# out of the repository; no shipped config names it). Use it with
#   slam-run ... --set Places.vocabulary=$PWD/out/places/orb_k16_l4.pvoc --set Places.directIndexLevelsUp=2 \
#                --set LoopClosing.enabled=true
#
# Data: the real recordings of ../shared/data (KITTI 00: 200 frames, TUM fr3_cabinet every 20th: 58) and synthetic
# scenes of a seed the evaluations do not use (room, corridor, street, jam; seed 11, 150 frames each).
# ORB: the extractor defaults (2000 features, 8 levels, 1.2), as config/slam/kitti.ini; k = 16, L = 4, seed 0 (65 228 words, 2.2 MB).
# Environment: BUILD_DIR (build), WORK_DIR (/tmp/vocab-train), OUT (out/places/orb_k16_l4.pvoc).
# Takes a few minutes on 2 cores (most of it rendering).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
WORK_DIR=${WORK_DIR:-/tmp/vocab-train}
OUT=${OUT:-out/places/orb_k16_l4.pvoc}
DATA=../shared/data
B="$BUILD_DIR/bin"
for tool in dataset2rawlog slam-synth vocab-train; do
  if [[ ! -x "$B/$tool" ]]; then
    echo "train-vocabulary.sh: $B/$tool not built (bash scripts/build.sh)" >&2
    exit 1
  fi
done
if [[ ! -d "$DATA/kitti_odometry/sequences/00" || ! -d "$DATA/tum_rgbd/rgbd_dataset_freiburg3_cabinet_every20th" ]]; then
  echo "train-vocabulary.sh: $DATA (KITTI 00, TUM fr3_cabinet) not found" >&2
  exit 1
fi
mkdir -p "$WORK_DIR" "$(dirname "$OUT")"
"$B/dataset2rawlog" "$DATA/kitti_odometry/sequences/00" -o "$WORK_DIR/kitti" --camera-ini config/cameras/kitti_00-02.ini -q
"$B/dataset2rawlog" "$DATA/tum_rgbd/rgbd_dataset_freiburg3_cabinet_every20th" -o "$WORK_DIR/tum" --name cabinet \
  --format tum --tum-camera fr3 -q
for s in room corridor street jam; do
  "$B/slam-synth" --scenario "$s" --seed 11 --frames 150 --out "$WORK_DIR/synth" --name "${s}_s11" --threads 2 --quiet
done
"$B/vocab-train" --out "$OUT" --branching 16 --depth 4 --seed 0 --every 1 \
  --rawlog "$WORK_DIR/kitti/kitti_00.rawlog" --rawlog "$WORK_DIR/tum/cabinet.rawlog" \
  --rawlog "$WORK_DIR/synth/room_s11.rawlog" --rawlog "$WORK_DIR/synth/corridor_s11.rawlog" \
  --rawlog "$WORK_DIR/synth/street_s11.rawlog" --rawlog "$WORK_DIR/synth/jam_s11.rawlog" \
  --description "scripts/train-vocabulary.sh: KITTI 00 (200 frames), TUM fr3_cabinet every 20th (58), slam-synth room/corridor/street/jam seed 11 (150 frames each); ORB defaults; k 16, L 4, seed 0"
echo "train-vocabulary.sh: $OUT written"
