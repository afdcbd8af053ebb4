#!/usr/bin/env bash
# Renders the training data and trains the monocular normal network shipped as
# config/manhattan/models/normals_unet_128x96.onnx (doc/normals_network.md). Maintainer step: CI and the
# README never train, they use the shipped model.
#
# Needs PyTorch for the system Python, which is not a project dependency (not in install-deps.sh):
#   apt-get install -y python3-torch python3-numpy python3-pil     # Debian 12; then /usr/bin/python3 has torch
# and a build with the normals-dataset tool (scripts/build.sh, or: cmake --build build --target normals-dataset).
#
# Environment: BUILD_DIR (build), DATA_DIR (/tmp/normals-data; large, keep it out of the repository),
# WORK_DIR (/tmp/normals-train), EPOCHS (8), SEED (7), THREADS (1: the CPU is shared), PYTHON (/usr/bin/python3).
# Training takes 10-40 minutes on one core (about 9 on a free core, 35 on a shared, loaded one); it writes
# the model, training.json and loss.png into WORK_DIR, then copies the model into config/manhattan/models/ and
# the loss curve into doc/img/.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
DATA_DIR=${DATA_DIR:-/tmp/normals-data}
WORK_DIR=${WORK_DIR:-/tmp/normals-train}
EPOCHS=${EPOCHS:-8}
SEED=${SEED:-7}
THREADS=${THREADS:-1}
PYTHON=${PYTHON:-/usr/bin/python3}

if ! "$PYTHON" -c 'import torch, numpy, PIL' 2>/dev/null; then
  echo "train-normals.sh: $PYTHON lacks torch/numpy/PIL; install them with:" >&2
  echo "  apt-get install -y python3-torch python3-numpy python3-pil" >&2
  exit 1
fi
if [[ ! -x "$BUILD_DIR/bin/normals-dataset" ]]; then
  echo "train-normals.sh: $BUILD_DIR/bin/normals-dataset not built (cmake --build $BUILD_DIR --target normals-dataset)" >&2
  exit 1
fi

# 1. Data: 3 indoor scenarios x 80 training seeds x 20 views, held-out seeds 1001-1004 (same recipe as the model card).
"$BUILD_DIR/bin/normals-dataset" --out "$DATA_DIR" --scenarios room,corridor,lowtexture \
  --first-train-seed 1 --train-seeds 80 --first-test-seed 1001 --test-seeds 4 --views 20 --width 128 --height 96

# 2. Training (deterministic for a given seed, thread count and PyTorch build) and ONNX export.
"$PYTHON" scripts/train_normals.py --data "$DATA_DIR" --out "$WORK_DIR" --epochs "$EPOCHS" --seed "$SEED" \
  --threads "$THREADS"

# 3. Ship.
mkdir -p config/manhattan/models doc/img
cp "$WORK_DIR/model.onnx" config/manhattan/models/normals_unet_128x96.onnx
cp "$WORK_DIR/loss.png" doc/img/normals_network_training.png
echo "train-normals.sh: config/manhattan/models/normals_unet_128x96.onnx and doc/img/normals_network_training.png updated;"
echo "  record $WORK_DIR/training.json in doc/normals_network.md and check the model with bench-normals (see there)."
