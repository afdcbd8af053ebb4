#!/usr/bin/env bash
# test-slurm-local.sh: self-test of scripts/slurm-local.sh.
#
# Usage: bash scripts/test-slurm-local.sh [ROUNDS]   (default 1)
#
# Each round: start a private cluster in a fresh temporary directory, submit
# a 2-task job array (one CPU per task) with sbatch, wait (at most 60 s) until
# both tasks wrote their output, check that the two tasks ran at the same
# time (when the machine has 2 or more CPUs), stop the cluster and check that
# no munged/slurmctld/slurmd/slurmstepd/slurmscriptd of that cluster is left. A round's
# directory is deleted when it passed and kept (with the daemons' logs) when
# it failed.
#
# Exit codes: 0 all rounds passed; 77 slurm-local.sh start said the cluster
# cannot run on this machine (its reason is printed); 1 a round failed.

set -uo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
SL="$HERE/slurm-local.sh"
ROUNDS=${1:-1}
case "$ROUNDS" in '' | *[!0-9]*) echo "usage: $0 [ROUNDS]" >&2; exit 2 ;; esac

log() { printf 'test-slurm-local: %s\n' "$*" >&2; }

now_ms() { date +%s%3N; }

# Live processes of the cluster in $1: a command line naming the directory
# (munged, slurmctld, slurmd, job scripts) or a slurm daemon running in it
# (slurmstepd, slurmscriptd). Zombies have neither and are not counted.
cluster_pids() {
  local dir=$1 p cmd comm cwd
  for p in /proc/[0-9]*; do
    cmd=$(tr '\0' ' ' 2>/dev/null <"$p/cmdline") || continue
    case "$cmd" in *"$dir/"*) echo "${p#/proc/} $cmd"; continue ;; esac
    read -r comm 2>/dev/null <"$p/comm" || continue
    case "$comm" in slurm* | munged) ;; *) continue ;; esac
    cwd=$(readlink "$p/cwd" 2>/dev/null) || continue
    case "$cwd/" in "$dir"/*) echo "${p#/proc/} $cmd (in $cwd)" ;; esac
  done
}

# One round; $1 = round number. Returns 0 pass, 1 fail, 77 skip.
round() {
  local n=$1 dir env rc t0 t1 job i
  dir=$(mktemp -d /tmp/slurm-local-test.XXXXXX) || return 1
  CUR_DIR=$dir

  t0=$(now_ms)
  env=$(bash "$SL" start "$dir" 2>"$dir.start.err")
  rc=$?
  t1=$(now_ms)
  if [ $rc -eq 77 ]; then
    log "skipped: $(tail -n1 "$dir.start.err")"
    bash "$SL" stop "$dir" 2>/dev/null
    rm -rf "$dir" "$dir.start.err"
    return 77
  fi
  if [ $rc -ne 0 ]; then
    sed 's/^/  /' "$dir.start.err" >&2
    log "round $n: start failed (exit $rc); logs kept in $dir"
    bash "$SL" stop "$dir"
    return 1
  fi
  START_MS+=("$((t1 - t0))")
  log "round $n: start took $((t1 - t0)) ms"

  (
    set -e
    eval "$env"
    [ -n "${SLURM_CONF:-}" ] && [ -r "$SLURM_CONF" ]
    mkdir "$dir/array"
    cat >"$dir/array/task.sh" <<EOF
#!/bin/sh
# One array task: note when it ran, hold its CPU a little, write its id.
date +%s.%N >"$dir/array/start_\$SLURM_ARRAY_TASK_ID"
sleep 3
date +%s.%N >"$dir/array/end_\$SLURM_ARRAY_TASK_ID"
echo "\$SLURM_ARRAY_TASK_ID" >"$dir/array/out_\$SLURM_ARRAY_TASK_ID"
EOF
    chmod +x "$dir/array/task.sh"
    cd "$dir/array"
    job=$(sbatch --parsable --array=0-1 --ntasks=1 --cpus-per-task=1 --time=2 \
            --output="$dir/array/slurm-%A_%a.out" "$dir/array/task.sh")
    job=${job%%;*}
    squeue -h -j "$job" -o '%i %T' >"$dir/array/squeue.txt"
    for ((i = 0; i < 600; i++)); do
      [ -s "$dir/array/out_0" ] && [ -s "$dir/array/out_1" ] && break
      sleep 0.1
    done
    if ! [ -s "$dir/array/out_0" ] || ! [ -s "$dir/array/out_1" ]; then
      echo "array job $job: outputs missing after 60 s" >&2
      squeue -h -j "$job" >&2 || true
      exit 1
    fi
    if [ "$(cat "$dir/array/out_0")" != 0 ] || [ "$(cat "$dir/array/out_1")" != 1 ]; then
      echo "array job $job: wrong task ids in outputs" >&2
      exit 1
    fi
    if [ "$(nproc)" -ge 2 ]; then
      # Both tasks started before either ended: they ran at the same time.
      awk 'FNR == 1 { v[FILENAME] = $1 }
           END { s = (v[ARGV[1]] > v[ARGV[2]]) ? v[ARGV[1]] : v[ARGV[2]];
                 e = (v[ARGV[3]] < v[ARGV[4]]) ? v[ARGV[3]] : v[ARGV[4]];
                 exit !(s < e) }' \
        "$dir/array/start_0" "$dir/array/start_1" "$dir/array/end_0" "$dir/array/end_1" ||
        { echo "array job $job: the two tasks did not run at the same time" >&2; exit 1; }
    fi
    echo "array job $job: both tasks done"
  ) >&2
  rc=$?

  bash "$SL" stop "$dir" 2>"$dir.stop.err" || rc=1
  local left
  left=$(cluster_pids "$dir")
  if [ -n "$left" ]; then
    log "round $n: processes left after stop:"
    printf '  %s\n' "$left" >&2
    rc=1
  fi
  if [ $rc -ne 0 ]; then
    cat "$dir.start.err" "$dir.stop.err" >&2
    log "round $n: FAILED; logs kept in $dir"
    return 1
  fi
  rm -rf "$dir" "$dir.start.err" "$dir.stop.err"
  CUR_DIR=""
  log "round $n: passed"
  return 0
}

CUR_DIR=""
START_MS=()
# On interruption, stop the cluster of the round in progress.
trap '[ -z "$CUR_DIR" ] || bash "$SL" stop "$CUR_DIR"' EXIT
trap 'exit 130' INT TERM

passed=0
failed=0
for ((r = 1; r <= ROUNDS; r++)); do
  round "$r"
  case $? in
    0) passed=$((passed + 1)) ;;
    77) CUR_DIR=""; exit 77 ;;
    *) failed=$((failed + 1)) ;;
  esac
done
if [ ${#START_MS[@]} -gt 0 ]; then
  log "start times (ms): ${START_MS[*]}"
fi
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
