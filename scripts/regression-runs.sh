#!/usr/bin/env bash
# The runs that say whether a change kept the system's behaviour: every shipped configuration on its own kind of
# scene, sequential mode, fixed seeds, so that two builds can be compared byte for byte.
#
#   bash scripts/regression-runs.sh render DATA            # the inputs (about 6 min on 2 cores; once)
#   bash scripts/regression-runs.sh run DATA OUT [BIN]     # the runs of the build in BIN (default build/bin)
#   bash scripts/regression-runs.sh compare OUT_A OUT_B    # cmp of every trajectory, keyframe list and map
#
# The runs (OUT/<name>/ as slam-run writes them):
#   kitti00         KITTI 00 (200 frames, ../shared/data), config/slam/kitti.ini
#   room            the demo's room (300 frames, scene seed 1), config/slam/synthetic.ini
#   room_lines      the same with line segments ([Lines] enabled)
#   room_lines_loc  localization in room_lines' map (the line store loaded back)
#   lowtexture      low-texture scene (300 frames, seed 1, ground-truth normals), config/slam/structure.ini
#   jam_direct      traffic jam (300 frames, seed 1): probabilistic + semantic model + direct points
#   jam_direct_loc  localization in jam_direct's map (the direct points loaded back)
#   corridor_loop   the corridor loop (907 frames, scene seed 2), synthetic.ini with loop closing
# KITTI 00 is skipped with a message when ../shared/data is absent. Exit status of compare: 0 when every file is
# identical, 1 otherwise (each difference is listed).
set -euo pipefail
cd "$(dirname "$0")/.."
usage() { sed -n '2,20p' "$0" >&2; exit 2; }
[ $# -ge 2 ] || usage
mode=$1
KITTI=../shared/data/kitti_odometry/sequences/00

render() {
  local data=$1 bin=${2:-build/bin}
  mkdir -p "$data"
  if [ -d "$KITTI" ]; then
    "$bin/dataset2rawlog" "$KITTI" -o "$data/kitti" --camera-ini config/cameras/kitti_00-02.ini >/dev/null
  else
    echo "regression-runs: $KITTI not found: KITTI 00 is skipped" >&2
  fi
  "$bin/slam-synth" --scenario room --frames 300 --seed 1 --out "$data/room" --quiet
  "$bin/slam-synth" --scenario lowtexture --frames 300 --seed 1 --out "$data/lowtexture" --quiet
  "$bin/slam-synth" --scenario jam --frames 300 --seed 1 --out "$data/jam" --quiet
  "$bin/slam-synth" --scenario corridor --seed 2 --out "$data/corridor" --quiet
}

run() {
  local data=$1 out=$2 bin=${3:-build/bin}
  local slam=("$bin/slam-run" -q)
  local direct=(--set PointModel.model=probabilistic --set PointModel.semantic=true
                --set Initializer.minStaticProbability=0.8 --set Initializer.minMatches=50
                --set Initializer.minMapPoints=50 --set DirectFeatures.enabled=true)
  mkdir -p "$out"
  if [ -f "$data/kitti/kitti_00.rawlog" ]; then
    "${slam[@]}" --config config/slam/kitti.ini --rawlog "$data/kitti/kitti_00.rawlog" --out "$out/kitti00" --seed 0
  fi
  "${slam[@]}" --config config/slam/synthetic.ini --rawlog "$data/room/room.rawlog" --out "$out/room" --seed 1
  "${slam[@]}" --config config/slam/synthetic.ini --rawlog "$data/room/room.rawlog" --out "$out/room_lines" --seed 1 \
    --set Lines.enabled=true
  "${slam[@]}" --config config/slam/synthetic.ini --rawlog "$data/room/room.rawlog" --out "$out/room_lines_loc" \
    --seed 1 --set Lines.enabled=true --map-in "$out/room_lines/map.slammap" --localization
  "${slam[@]}" --config config/slam/structure.ini --rawlog "$data/lowtexture/lowtexture.rawlog" \
    --out "$out/lowtexture" --seed 1
  "${slam[@]}" --config config/slam/synthetic.ini --rawlog "$data/jam/jam.rawlog" --out "$out/jam_direct" --seed 1 \
    "${direct[@]}"
  "${slam[@]}" --config config/slam/synthetic.ini --rawlog "$data/jam/jam.rawlog" --out "$out/jam_direct_loc" \
    --seed 1 "${direct[@]}" --map-in "$out/jam_direct/map.slammap" --localization
  "${slam[@]}" --config config/slam/synthetic.ini --rawlog "$data/corridor/corridor.rawlog" --out "$out/corridor_loop" \
    --seed 0
}

compare() {
  local a=$1 b=$2 status=0 n=0
  for dir in "$a"/*/; do
    local name
    name=$(basename "$dir")
    for f in trajectory.txt keyframes.txt map.slammap; do
      [ -f "$a/$name/$f" ] || continue
      n=$((n + 1))
      if ! cmp -s "$a/$name/$f" "$b/$name/$f"; then
        echo "differs: $name/$f"
        status=1
      fi
    done
  done
  echo "regression-runs: compared $n files of $a and $b: $([ $status = 0 ] && echo identical || echo 'NOT identical')"
  return $status
}

case $mode in
  render) render "${@:2}" ;;
  run) [ $# -ge 3 ] || usage; run "${@:2}" ;;
  compare) [ $# -eq 3 ] || usage; compare "$2" "$3" ;;
  *) usage ;;
esac
