#!/usr/bin/env bash
# Trains a bag-of-words vocabulary (doc/places.md). Generated data: never in the repository.
#
#   bash scripts/train-vocabulary.sh              the default vocabulary, config/places/orb_synth_k16_l4.pvoc
#                                                 (ignored by git). The build runs this (CMake target `vocabulary`,
#                                                 option PRIORSLAM_BUILD_VOCABULARY): the general configs name it.
#   bash scripts/train-vocabulary.sh --with-shared-data
#                                                 the same scenes plus the real recordings of ../shared/data into
#                                                 out/places/orb_k16_l4.pvoc (the earlier recipe of doc/places.md)
#
# Default recipe: only what the project renders itself, so every machine trains the same bytes: slam-synth room,
# corridor, street and jam, seed 11 (a seed the evaluations do not use), 150 frames each, every frame.
# --with-shared-data adds KITTI 00 (200 frames) and TUM fr3_cabinet every 20th (58).
# ORB: the extractor defaults (2000 features, 8 levels, 1.2), as config/slam/kitti.ini; k = 16, L = 4, seed 0
# (about 65 000 words, 2.2 MB). About a minute on 2 cores (rendering 35 s, extraction 9 s, clustering 8 s).
# Environment: BUILD_DIR (build; its bin/ holds the tools), SLAM_SYNTH, VOCAB_TRAIN, DATASET2RAWLOG (tool paths;
# default $BUILD_DIR/bin/...), WORK_DIR (a new temporary folder, removed afterwards), OUT (the output file).
set -euo pipefail
cd "$(dirname "$0")/.."
WITH_SHARED=0
case "${1:-}" in
  "") ;;
  --with-shared-data) WITH_SHARED=1 ;;
  *) echo "usage: bash scripts/train-vocabulary.sh [--with-shared-data]" >&2; exit 2 ;;
esac
BUILD_DIR=${BUILD_DIR:-build}
SLAM_SYNTH=${SLAM_SYNTH:-$BUILD_DIR/bin/slam-synth}
VOCAB_TRAIN=${VOCAB_TRAIN:-$BUILD_DIR/bin/vocab-train}
DATASET2RAWLOG=${DATASET2RAWLOG:-$BUILD_DIR/bin/dataset2rawlog}
if [[ $WITH_SHARED == 1 ]]; then
  OUT=${OUT:-out/places/orb_k16_l4.pvoc}
else
  OUT=${OUT:-config/places/orb_synth_k16_l4.pvoc}
fi
DATA=../shared/data
tools=("$SLAM_SYNTH" "$VOCAB_TRAIN")
if [[ $WITH_SHARED == 1 ]]; then tools+=("$DATASET2RAWLOG"); fi
for tool in "${tools[@]}"; do
  if [[ ! -x "$tool" ]]; then
    echo "train-vocabulary.sh: $tool not built (bash scripts/build.sh)" >&2
    exit 1
  fi
done
if [[ $WITH_SHARED == 1 && ( ! -d "$DATA/kitti_odometry/sequences/00" ||
                             ! -d "$DATA/tum_rgbd/rgbd_dataset_freiburg3_cabinet_every20th" ) ]]; then
  echo "train-vocabulary.sh: $DATA (KITTI 00, TUM fr3_cabinet) not found" >&2
  exit 1
fi
if [[ -n "${WORK_DIR:-}" ]]; then
  mkdir -p "$WORK_DIR"
else
  WORK_DIR=$(mktemp -d /tmp/vocab-train.XXXXXX)
  trap 'rm -rf "$WORK_DIR"' EXIT
fi
mkdir -p "$(dirname "$OUT")"

rawlogs=()
description="scripts/train-vocabulary.sh:"
if [[ $WITH_SHARED == 1 ]]; then
  "$DATASET2RAWLOG" "$DATA/kitti_odometry/sequences/00" -o "$WORK_DIR/kitti" \
    --camera-ini config/cameras/kitti_00-02.ini -q
  "$DATASET2RAWLOG" "$DATA/tum_rgbd/rgbd_dataset_freiburg3_cabinet_every20th" -o "$WORK_DIR/tum" --name cabinet \
    --format tum --tum-camera fr3 -q
  rawlogs+=(--rawlog "$WORK_DIR/kitti/kitti_00.rawlog" --rawlog "$WORK_DIR/tum/cabinet.rawlog")
  description+=" KITTI 00 (200 frames), TUM fr3_cabinet every 20th (58),"
fi
for s in room corridor street jam; do
  echo "train-vocabulary.sh: rendering $s (seed 11, 150 frames)" >&2
  "$SLAM_SYNTH" --scenario "$s" --seed 11 --frames 150 --out "$WORK_DIR/synth" --name "${s}_s11" --threads 2 \
    --quiet > /dev/null
  rawlogs+=(--rawlog "$WORK_DIR/synth/${s}_s11.rawlog")
done
description+=" slam-synth room/corridor/street/jam seed 11 (150 frames each); ORB defaults; k 16, L 4, seed 0"
# vocab-train writes a temporary file and renames it: an interrupted run leaves no vocabulary behind.
"$VOCAB_TRAIN" --out "$OUT" --branching 16 --depth 4 --seed 0 --every 1 "${rawlogs[@]}" \
  --description "$description" -q
echo "train-vocabulary.sh: $OUT written" >&2
