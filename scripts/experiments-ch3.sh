#!/usr/bin/env bash
# Chapter-3 experiments (doc/experiments.md): the map-point models of Table 3.3 on one rawlog, same frames, same
# seed, one after the other, and a Markdown table row per model with ATE, RPE, DR, tracked frames and CPU.
#
# usage: scripts/experiments-ch3.sh --rawlog R --gt GT --config C --out DIR [--seed S] [--name NAME]
#                                   [--bin build/bin] [--modes "heuristic masking probabilistic prob-semantic"]
#   R    rawlog (with SEMANTIC for the semantic modes, with DEPTH for DR)
#   GT   ground-truth trajectory (TUM)
# Modes (the --set overrides each one passes to slam-run):
#   heuristic        PointModel.model=heuristic (ORB-SLAM*)
#   masking          PointModel.model=masking (points with P(dynamic) > 0.5 are inactive)
#   probabilistic    PointModel.model=probabilistic, PointModel.semantic=false (geometry alone)
#   prob-semantic    PointModel.model=probabilistic, PointModel.semantic=true,
#                    Initializer.minStaticProbability=0.8 (p_min^static of Table 3.2, §3.4.1), and ORB-SLAM's
#                    100-match / 100-point initializer thresholds halved (minMatches = minMapPoints = 50): the
#                    filter removes 70-85 % of the jam's keypoints (doc/experiments.md)
#   prob-semantic-noinit  the same without the initialization filter (minStaticProbability=0)
#   --table-only     no runs: the rows from the outputs already in DIR
# Outputs: DIR/<mode>/ (slam-run outputs + eval.json), DIR/table.md (appended rows). ATE is over the poses of
# trajectory.txt (the final map after any reset), their number in parentheses.
set -euo pipefail

BIN=build/bin
SEED=1
NAME=""
MODES="heuristic masking probabilistic prob-semantic prob-semantic-noinit"
TABLE_ONLY=0
RAWLOG="" GT="" CONFIG="" OUT=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --rawlog) RAWLOG=$2; shift 2 ;;
    --gt) GT=$2; shift 2 ;;
    --config) CONFIG=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --seed) SEED=$2; shift 2 ;;
    --name) NAME=$2; shift 2 ;;
    --bin) BIN=$2; shift 2 ;;
    --modes) MODES=$2; shift 2 ;;
    --table-only) TABLE_ONLY=1; shift ;;
    -h|--help) sed -n 2,21p "$0"; exit 0 ;;
    *) echo "experiments-ch3: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
for v in RAWLOG GT CONFIG OUT; do
  [[ -n "${!v}" ]] || { echo "experiments-ch3: --${v,,} is required (see --help)" >&2; exit 2; }
done
for f in "$RAWLOG" "$GT" "$CONFIG"; do
  [[ -f "$f" ]] || { echo "experiments-ch3: $f: file not found" >&2; exit 2; }
done
for t in slam-run slam-eval; do
  [[ -x "$BIN/$t" ]] || { echo "experiments-ch3: $BIN/$t not built (bash scripts/build.sh)" >&2; exit 2; }
done
NAME=${NAME:-$(basename "$RAWLOG" .rawlog)}
mkdir -p "$OUT"

overrides() {
  case "$1" in
    heuristic) echo "--set PointModel.model=heuristic" ;;
    masking) echo "--set PointModel.model=masking --set PointModel.semantic=true" ;;
    probabilistic) echo "--set PointModel.model=probabilistic --set PointModel.semantic=false" ;;
    prob-semantic) echo "--set PointModel.model=probabilistic --set PointModel.semantic=true --set Initializer.minStaticProbability=0.8 --set Initializer.minMatches=50 --set Initializer.minMapPoints=50" ;;
    prob-semantic-noinit) echo "--set PointModel.model=probabilistic --set PointModel.semantic=true --set Initializer.minStaticProbability=0" ;;
    *) echo "experiments-ch3: unknown mode '$1'" >&2; exit 2 ;;
  esac
}

[[ -f "$OUT/table.md" ]] || {
  echo "| sequence | seed | model | init frame | tracked % | ATE rmse [m] (poses) | RPE t rmse [m] | DR [%] | CPU ms/frame | command |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
} > "$OUT/table.md"

for mode in $MODES; do
  dir="$OUT/$mode"
  if [[ $TABLE_ONLY == 0 ]]; then
  # shellcheck disable=SC2046
  "$BIN/slam-run" --config "$CONFIG" --rawlog "$RAWLOG" --out "$dir" --seed "$SEED" -q $(overrides "$mode")
  evalArgs=("$GT" "$dir/trajectory.txt" --align sim3 --json "$dir/eval.json")
  # DR needs the DEPTH channel; slam-eval says so when it is missing, the cell is then "-".
  drArgs=(--depths "$dir/depths.txt" --rawlog "$RAWLOG" --dr-scale)
  if [[ -s "$dir/trajectory.txt" ]] && grep -qv '^#' "$dir/trajectory.txt"; then
    "$BIN/slam-eval" "${evalArgs[@]}" "${drArgs[@]}" > "$dir/eval.txt" 2>&1 ||
      "$BIN/slam-eval" "${evalArgs[@]}" > "$dir/eval.txt" 2>&1 || true
  fi
  fi
  python3 - "$dir" "$NAME" "$SEED" "$mode" "$(overrides "$mode")" >> "$OUT/table.md" <<'EOF'
import json, os, sys
d, name, seed, mode, sets = sys.argv[1:6]
s = json.load(open(os.path.join(d, "report.json")))["summary"]
frames = max(1, s["frames_processed"])
tracked = 100.0 * s["frames_tracked"] / frames
cpu = 1000.0 * s["cpu_seconds"] / frames
init = s["initialized_at_frame"] if s["initialized"] else "never"
ate = rpe = dr = "-"
ev = os.path.join(d, "eval.json")
if os.path.exists(ev):
    e = json.load(open(ev))
    ate = "%.3f (%d)" % (e["ate"]["rmse"], e["ate"]["count"])
    if "rpe" in e and "translation" in e["rpe"]:
        rpe = "%.3f" % e["rpe"]["translation"]["rmse"]
    if "dr" in e:
        dr = "%.1f" % (100.0 * e["dr"]["ratio"])
print("| %s | %s | %s | %s | %.1f | %s | %s | %s | %.1f | `%s` |" % (name, seed, mode, init, tracked, ate, rpe, dr, cpu, sets))
EOF
done
tail -n +3 "$OUT/table.md"
