#!/usr/bin/env bash
# slurm-local.sh: a private single-node Slurm cluster on localhost, for the
# tests of `slam-batch submit --backend slurm`.
#
# Usage:
#   eval "$(bash scripts/slurm-local.sh start DIR)"
#       Creates DIR (if needed), starts munged, slurmctld and slurmd from
#       files kept in DIR, waits until the node is idle and runs one trivial
#       batch job through it. On success prints on stdout the lines a client
#       needs, currently only
#           export SLURM_CONF=DIR/slurm.conf
#       (sbatch/squeue/sinfo/scancel then talk to this cluster, and find its
#       munge socket through AuthInfo in that file). Progress and errors go to
#       stderr.
#   bash scripts/slurm-local.sh stop DIR
#       Cancels the cluster's jobs, then stops the daemons whose pids are
#       recorded in DIR (slurmd, slurmctld, then munged; a pid is used only
#       while that process's command line still names DIR), and any
#       slurmstepd/slurmscriptd they left behind (named so and running in
#       DIR, where the daemons are started) together with the job processes
#       under those. Idempotent; also cleans up after a failed start.
#       Deletes nothing: DIR stays for inspection (logs), the caller may
#       remove it.
#   bash scripts/slurm-local.sh status DIR
#       Prints the pids of the running daemons and `sinfo` output.
#
# Exit codes of start:
#   0   cluster running and a test job completed on it
#   77  the daemons cannot be started on this machine (packages missing, a
#       daemon refused to start or died, e.g. under container restrictions or
#       as a non-root user where slurmd cannot run); the last line on stderr,
#       "slurm-local: SKIP: <reason>", says why. Nothing is left running.
#   1   a real failure: the cluster came up but the test job did not run,
#       DIR cannot be used (not writable, or its path too long for the unix
#       sockets in it: keep it under about 70 characters), or DIR's cluster
#       is already running
#   2   usage error
# stop and status exit 0 (status exits 1 when nothing of DIR is running).
#
# What start creates in DIR (nothing outside it; /etc and the system's
# munge/slurm services are never touched):
#   munge.key (0400, fresh random key), munge.socket, munged.pid,
#   munged.log, munged.seed
#   slurm.conf, plugstack.conf (empty), slurmctld.pid, slurmd.pid,
#   slurmctld.log, slurmd.log, state/ (StateSaveLocation),
#   spool/ (SlurmdSpoolDir), check/ (output of the start-up test job),
#   munged.out, slurmctld.out, slurmd.out (the daemons' early stderr)
# A start in a DIR used before replaces these (state and spool start empty)
# and leaves any other file there alone.
# slurm.conf uses free TCP ports picked at start for SlurmctldPort and
# SlurmdPort; clients and daemons talk over 127.0.0.1 only (the daemons
# themselves listen on all addresses, as Slurm 22.05 has no bind option).
# SlurmUser/SlurmdUser are the current user, root or not; jobs run as that
# user. DIR is made mode 0700, so other local users cannot reach the munge
# socket and hence the cluster.
#
# Environment knobs: SLURM_LOCAL_TIMEOUT (seconds to wait for the node to
# become idle and, separately, for the test job; default 30).
#
# Needs the Debian 12 packages slurmctld slurmd slurm-client munge
# (scripts/install-deps.sh installs them).

set -uo pipefail

PROG=slurm-local
TIMEOUT=${SLURM_LOCAL_TIMEOUT:-30}

log() { printf '%s: %s\n' "$PROG" "$*" >&2; }

usage() {
  echo "usage: $0 start|stop|status DIR" >&2
  exit 2
}

# ---------------------------------------------------------------- helpers

# Prints the pid in file $1 if it names a live process whose command line
# contains $2 (so a recycled pid of another process is never used).
live_pid() {
  local file=$1 marker=$2 pid cmd
  [ -r "$file" ] || return 1
  pid=$(tr -dc '0-9' 2>/dev/null <"$file")
  [ -n "$pid" ] || return 1
  [ -r "/proc/$pid/cmdline" ] || return 1
  cmd=$(tr '\0' ' ' 2>/dev/null <"/proc/$pid/cmdline") || return 1
  case "$cmd" in
    *"$marker"*) printf '%s\n' "$pid" ;;
    *) return 1 ;;
  esac
}

# Pids of slurm processes left behind by our daemons: slurmstepd (one per
# job step, reparented to init), slurmscriptd, or a slurmd/slurmctld whose
# pid file is gone. They are recognised by their name and their working
# directory, which is DIR (the daemons are started there and stay there).
stray_pids() {
  local p comm cwd
  for p in /proc/[0-9]*; do
    read -r comm 2>/dev/null <"$p/comm" || continue
    case "$comm" in slurmstepd | slurmscriptd | slurmd | slurmctld) ;; *) continue ;; esac
    cwd=$(readlink "$p/cwd" 2>/dev/null) || continue
    case "$cwd" in "$DIR" | "$DIR/spool" | "$DIR/spool/"*) printf '%s\n' "${p#/proc/}" ;; esac
  done
}

# Pids of all descendants of the given pids (the processes of a job whose
# slurmstepd is stray).
descendants() {
  cat /proc/[0-9]*/status 2>/dev/null | awk -v roots=" $* " '
    /^Pid:/ { pid = $2 }
    /^PPid:/ { pp[pid] = $2 }
    END {
      n = split(roots, r, " ")
      for (i = 1; i <= n; i++) keep[r[i]] = 1
      for (changed = 1; changed; ) {
        changed = 0
        for (p in pp) if (!(p in keep) && (pp[p] in keep)) { keep[p] = 1; changed = 1 }
      }
      for (p in keep) if (!index(roots, " " p " ")) print p
    }'
}

# Sends TERM to the given pids, waits up to $1 seconds, then KILLs the rest.
terminate() {
  local wait_s=$1 p alive i
  shift
  [ $# -gt 0 ] || return 0
  kill -TERM "$@" 2>/dev/null
  for ((i = 0; i < wait_s * 10; i++)); do
    alive=()
    for p in "$@"; do
      if kill -0 "$p" 2>/dev/null && ! grep -qs '^State:.*Z' "/proc/$p/status"; then
        alive+=("$p")
      fi
    done
    [ ${#alive[@]} -gt 0 ] || return 0
    sleep 0.1
  done
  log "killing ${alive[*]} (did not stop on TERM within ${wait_s}s)"
  kill -KILL "${alive[@]}" 2>/dev/null
  return 0
}

port_in_use() {
  local hex
  hex=$(printf ':%04X' "$1")
  awk -v h="$hex" 'FNR > 1 && substr($2, length($2) - 4) == h { f = 1 }
                   END { exit !f }' /proc/net/tcp /proc/net/tcp6 2>/dev/null
}

# Prints a TCP port in 20000..59999 that no socket uses and that differs
# from $1 (if given).
free_port() {
  local p i
  for ((i = 0; i < 200; i++)); do
    p=$((20000 + (RANDOM * 32768 + RANDOM) % 40000))
    [ "$p" != "${1:-}" ] || continue
    port_in_use "$p" || { echo "$p"; return 0; }
  done
  return 1
}

log_tail() {
  [ -r "$1" ] || return 0
  grep -v '^\s*$' "$1" | tail -n "${2:-1}" | sed 's/^\[[^]]*\] //'
}

# ------------------------------------------------------------------ stop

stop_cluster() {
  [ -d "$DIR" ] || return 0
  local pid pids=() stray

  # Cancel the jobs first so slurmstepd cleans up their processes.
  if live_pid "$DIR/slurmctld.pid" "$DIR/slurm.conf" >/dev/null &&
     [ -r "$DIR/slurm.conf" ]; then
    SLURM_CONF="$DIR/slurm.conf" timeout 10 scancel --quiet \
      --user="$(id -un)" >/dev/null 2>&1
    local i
    for ((i = 0; i < 50; i++)); do
      [ -z "$(SLURM_CONF="$DIR/slurm.conf" timeout 5 squeue -h -o %i 2>/dev/null)" ] && break
      sleep 0.2
    done
  fi

  # slurmd before slurmctld, munged last (the others use it while stopping).
  if pid=$(live_pid "$DIR/slurmd.pid" "$DIR/slurm.conf"); then pids+=("$pid"); fi
  if pid=$(live_pid "$DIR/slurmctld.pid" "$DIR/slurm.conf"); then pids+=("$pid"); fi
  if [ ${#pids[@]} -gt 0 ]; then
    log "stopping slurm daemons (pids ${pids[*]})"
    terminate 15 "${pids[@]}"
  fi

  # Leftovers of the slurm daemons, with the job processes under them
  # (slurmstepd ignores TERM and leaves its job running when killed).
  local munged_pid="" kids
  munged_pid=$(live_pid "$DIR/munged.pid" "$DIR/munge.socket") || munged_pid=""
  mapfile -t stray < <(stray_pids)
  if [ ${#stray[@]} -gt 0 ]; then
    mapfile -t kids < <(descendants "${stray[@]}")
    log "stopping processes left by the slurm daemons (pids ${stray[*]} ${kids[*]})"
    [ ${#kids[@]} -eq 0 ] || terminate 5 "${kids[@]}"
    terminate 2 "${stray[@]}"
  fi

  if [ -n "$munged_pid" ]; then
    log "stopping munged (pid $munged_pid)"
    terminate 10 "$munged_pid"
  fi
  return 0
}

# ----------------------------------------------------------------- start

START_DONE=0
on_start_exit() {
  [ "$START_DONE" = 1 ] && return
  stop_cluster
}

skip() {
  stop_cluster
  START_DONE=1
  log "SKIP: $*"
  exit 77
}

fail() {
  stop_cluster
  START_DONE=1
  log "error: $*"
  exit 1
}

# Waits until the daemon writing pid file $1 is alive (cmdline contains $2).
wait_daemon() {
  local file=$1 marker=$2 i
  for ((i = 0; i < TIMEOUT * 10; i++)); do
    live_pid "$file" "$marker" >/dev/null && return 0
    sleep 0.1
  done
  return 1
}

start_cluster() {
  local b missing=()
  for b in munged slurmctld slurmd sbatch squeue sinfo scontrol scancel; do
    command -v "$b" >/dev/null 2>&1 || missing+=("$b")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    # $PATH may lack /usr/sbin for a non-root user.
    PATH="$PATH:/usr/sbin:/sbin"
    missing=()
    for b in munged slurmctld slurmd sbatch squeue sinfo scontrol scancel; do
      command -v "$b" >/dev/null 2>&1 || missing+=("$b")
    done
  fi
  if [ ${#missing[@]} -gt 0 ]; then
    log "SKIP: not installed: ${missing[*]} (Debian packages: slurmctld slurmd slurm-client munge)"
    exit 77
  fi
  if ! [ -r /proc/self/cmdline ] || ! [ -r /proc/meminfo ]; then
    log "SKIP: /proc is not readable"
    exit 77
  fi

  if ! mkdir -p "$DIR" 2>/dev/null || ! [ -w "$DIR" ]; then
    log "error: cannot create or write $DIR"
    exit 1
  fi
  DIR=$(cd "$DIR" && pwd -P) || exit 1
  local host max_len
  host=$(hostname -s 2>/dev/null || uname -n)
  host=${host%%.*}
  [ -n "$host" ] || { log "error: cannot determine the host name"; exit 1; }
  # A unix socket path holds at most 107 bytes; the longest one is
  # slurmstepd's DIR/spool/<host>_<jobid>.<stepid> (ids up to 10 digits).
  max_len=$((107 - ${#host} - 29))
  if [ ${#DIR} -gt "$max_len" ]; then
    log "error: $DIR is too long for the unix sockets in it (at most $max_len characters here)"
    exit 1
  fi
  if live_pid "$DIR/slurmctld.pid" "$DIR/slurm.conf" >/dev/null ||
     live_pid "$DIR/slurmd.pid" "$DIR/slurm.conf" >/dev/null ||
     live_pid "$DIR/munged.pid" "$DIR/munge.socket" >/dev/null; then
    log "error: a cluster from $DIR is already running; run '$0 stop $DIR' first"
    exit 1
  fi

  START_DONE=0
  trap on_start_exit EXIT
  trap 'exit 130' INT
  trap 'exit 143' TERM

  local t0=$SECONDS user cpus mem_mb ctld_port slurmd_port
  user=$(id -un) || fail "cannot determine the user name"
  cpus=$(nproc 2>/dev/null || echo 1)
  mem_mb=$(awk '/^MemTotal:/ { printf "%d", $2 / 1024 }' /proc/meminfo)
  [ -n "$mem_mb" ] && [ "$mem_mb" -gt 0 ] || mem_mb=1024
  ctld_port=$(free_port) || fail "no free TCP port found"
  slurmd_port=$(free_port "$ctld_port") || fail "no free TCP port found"

  chmod 0700 "$DIR"
  rm -rf "$DIR/state" "$DIR/spool" "$DIR/check"
  local d
  for d in munged slurmctld slurmd; do
    rm -f "$DIR/$d.pid" "$DIR/$d.log" "$DIR/$d.out"
  done
  rm -f "$DIR/munge.key" "$DIR/munge.socket" "$DIR/munge.socket.lock"
  mkdir -p "$DIR/state" "$DIR/spool" "$DIR/check" || fail "cannot create directories in $DIR"

  export SLURM_CONF="$DIR/slurm.conf"
  # The daemons run in DIR, so stop can recognise what they leave behind.
  cd "$DIR" || fail "cannot enter $DIR"

  # ---- munge
  log "creating munge key and starting munged"
  if command -v mungekey >/dev/null 2>&1; then
    mungekey --create --keyfile="$DIR/munge.key" >/dev/null 2>&1 ||
      dd if=/dev/urandom of="$DIR/munge.key" bs=1024 count=1 status=none
  else
    dd if=/dev/urandom of="$DIR/munge.key" bs=1024 count=1 status=none
  fi
  [ -s "$DIR/munge.key" ] || fail "cannot create $DIR/munge.key"
  chmod 0400 "$DIR/munge.key"
  # --force: start even if a directory above DIR is group/world-writable.
  if ! munged --force --key-file="$DIR/munge.key" --socket="$DIR/munge.socket" \
      --pid-file="$DIR/munged.pid" --log-file="$DIR/munged.log" \
      --seed-file="$DIR/munged.seed" </dev/null >"$DIR/munged.out" 2>&1; then
    skip "munged did not start: $(log_tail "$DIR/munged.out")"
  fi
  wait_daemon "$DIR/munged.pid" "$DIR/munge.socket" ||
    skip "munged did not start: $(log_tail "$DIR/munged.log")"

  # ---- slurm.conf
  : >"$DIR/plugstack.conf"
  cat >"$DIR/slurm.conf" <<EOF
# Generated by scripts/slurm-local.sh: a private one-node test cluster.
ClusterName=slamlocal
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$DIR/munge.socket
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/slurmctld.log
SlurmdLogFile=$DIR/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
PlugStackConfig=$DIR/plugstack.conf
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
SchedulerParameters=batch_sched_delay=0
MpiDefault=none
ReturnToService=2
SlurmdParameters=config_overrides
MailProg=/bin/true
InactiveLimit=0
KillWait=5
MinJobAge=300
SlurmdTimeout=300
NodeName=$host NodeAddr=127.0.0.1 NodeHostname=$host CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF

  # ---- slurmctld, slurmd
  log "starting slurmctld (port $ctld_port) and slurmd (port $slurmd_port) on node $host"
  if ! slurmctld -f "$DIR/slurm.conf" </dev/null >"$DIR/slurmctld.out" 2>&1; then
    skip "slurmctld did not start: $(log_tail "$DIR/slurmctld.out")$(log_tail "$DIR/slurmctld.log")"
  fi
  wait_daemon "$DIR/slurmctld.pid" "$DIR/slurm.conf" ||
    skip "slurmctld did not start: $(log_tail "$DIR/slurmctld.log")"
  if ! slurmd -f "$DIR/slurm.conf" -N "$host" </dev/null >"$DIR/slurmd.out" 2>&1; then
    skip "slurmd did not start: $(log_tail "$DIR/slurmd.out")$(log_tail "$DIR/slurmd.log")"
  fi
  wait_daemon "$DIR/slurmd.pid" "$DIR/slurm.conf" ||
    skip "slurmd did not start: $(log_tail "$DIR/slurmd.log")"

  # ---- wait for the node
  local i state=""
  for ((i = 0; i < TIMEOUT * 5; i++)); do
    live_pid "$DIR/slurmctld.pid" "$DIR/slurm.conf" >/dev/null ||
      skip "slurmctld died: $(log_tail "$DIR/slurmctld.log")"
    live_pid "$DIR/slurmd.pid" "$DIR/slurm.conf" >/dev/null ||
      skip "slurmd died: $(log_tail "$DIR/slurmd.log")"
    state=$(timeout 5 sinfo -h -N -n "$host" -o %T 2>/dev/null | head -n1)
    [ "$state" = idle ] && break
    sleep 0.2
  done
  [ "$state" = idle ] ||
    skip "node $host not idle after ${TIMEOUT}s (state '${state:-none}'): $(log_tail "$DIR/slurmd.log")"
  log "node $host idle after $((SECONDS - t0))s; running a test job"

  # ---- test job
  local job jstate=""
  job=$(cd "$DIR/check" && timeout 10 sbatch --parsable --job-name=slurm-local-check \
          --output="$DIR/check/job-%j.out" --time=1 \
          --wrap="echo slurm-local-ok" 2>"$DIR/check/sbatch.err") ||
    fail "sbatch of the test job failed: $(log_tail "$DIR/check/sbatch.err")"
  job=${job%%;*}
  for ((i = 0; i < TIMEOUT * 5; i++)); do
    jstate=$(timeout 5 scontrol show job -o "$job" 2>/dev/null |
               sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p')
    case "$jstate" in
      COMPLETED) break ;;
      FAILED | CANCELLED | TIMEOUT | NODE_FAIL | BOOT_FAIL | OUT_OF_MEMORY | DEADLINE | PREEMPTED)
        fail "test job $job ended $jstate: $(log_tail "$DIR/slurmd.log" 3 | tr '\n' ' ')" ;;
    esac
    sleep 0.2
  done
  [ "$jstate" = COMPLETED ] ||
    fail "test job $job not completed after ${TIMEOUT}s (state '${jstate:-unknown}')"
  grep -qx slurm-local-ok "$DIR/check/job-$job.out" 2>/dev/null ||
    fail "test job $job completed but wrote no output to $DIR/check/job-$job.out"

  START_DONE=1
  trap - EXIT INT TERM
  log "cluster ready in $((SECONDS - t0))s (test job $job completed)"
  printf 'export SLURM_CONF=%q\n' "$DIR/slurm.conf"
}

# ---------------------------------------------------------------- status

status_cluster() {
  [ -d "$DIR" ] || { log "$DIR does not exist"; return 1; }
  local any=1 pid
  if pid=$(live_pid "$DIR/munged.pid" "$DIR/munge.socket"); then echo "munged    $pid"; any=0; fi
  if pid=$(live_pid "$DIR/slurmctld.pid" "$DIR/slurm.conf"); then echo "slurmctld $pid"; any=0; fi
  if pid=$(live_pid "$DIR/slurmd.pid" "$DIR/slurm.conf"); then echo "slurmd    $pid"; any=0; fi
  if [ $any = 0 ] && live_pid "$DIR/slurmctld.pid" "$DIR/slurm.conf" >/dev/null; then
    SLURM_CONF="$DIR/slurm.conf" timeout 10 sinfo
  fi
  [ $any = 0 ] || log "nothing running from $DIR"
  return $any
}

# ------------------------------------------------------------------ main

[ $# -eq 2 ] || usage
[ -n "$2" ] || usage
case "$TIMEOUT" in '' | *[!0-9]*) echo "SLURM_LOCAL_TIMEOUT must be a number of seconds" >&2; exit 2 ;; esac
CMD=$1
DIR=$2
case "$CMD" in
  start) start_cluster ;;
  stop)
    if [ -d "$DIR" ]; then DIR=$(cd "$DIR" && pwd -P) || exit 1; fi
    stop_cluster
    ;;
  status)
    DIR=$(cd "$DIR" 2>/dev/null && pwd -P) || { log "$2 does not exist"; exit 1; }
    status_cluster
    ;;
  *) usage ;;
esac
