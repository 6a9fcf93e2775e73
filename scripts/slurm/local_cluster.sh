#!/usr/bin/env bash
# Starts and stops a private single-node Slurm cluster on localhost, for tests that submit jobs (job arrays,
# dependencies, sbatch --wait) to a real Slurm. Written for Debian 12's slurmctld, slurmd, slurm-client and munge
# (Slurm 22.05, munge 0.5.15) on a machine without systemd: the daemons are started directly. Needs root: all
# three daemons run as root (SlurmUser=SlurmdUser=root), and jobs run as their submitter.
#
# Usage:
#   eval "$(scripts/slurm/local_cluster.sh start DIR)"   # prints one line: export SLURM_CONF=DIR/slurm.conf
#   sbatch --array=0-3 --wrap '...'; squeue; ...
#   scripts/slurm/local_cluster.sh stop DIR
#
# start DIR  creates DIR (resolved to an absolute path) and writes everything the cluster needs inside it:
#              DIR/slurm.conf                 the configuration (daemons get -f, clients SLURM_CONF)
#              DIR/munge/munge.key            a fresh munge key of its own (mode 0400)
#              DIR/munge/munge.socket.2       its own munged's socket (slurm.conf: AuthInfo=socket=...; the
#                                             job credentials, cred/munge, go through it too); munged.seed
#              DIR/plugstack.conf             empty: no SPANK plugins (not the system's /etc/slurm one)
#              DIR/state/  DIR/spool/         slurmctld's StateSaveLocation, slurmd's SlurmdSpoolDir
#              DIR/{munged,slurmctld,slurmd}.pid   the daemons' PIDs (what `stop` kills)
#              DIR/{slurmctld,slurmd}.log     Slurm's logs; DIR/{munged,slurmctld,slurmd}.out the daemons'
#                                             stdout/stderr (munged's only log; the others' copy of theirs)
#              DIR/jobcomp.log                one line per finished job (JobState, ExitCode): jobcomp/filetxt,
#                                             readable without sacct or slurmdbd
#            then starts munged, slurmctld (with -c: clean state) and slurmd in the foreground of their own
#            sessions (setsid, so the PIDs are known at once), waits (RESTIR_SLURM_START_TIMEOUT, default 60 s)
#            until sinfo reports the node idle and prints `export SLURM_CONF=DIR/slurm.conf` on stdout; all
#            progress goes to stderr. On failure it prints the tail of the daemons' logs, stops what it started
#            and exits non-zero.
# stop DIR   cancels the cluster's remaining jobs (if its slurmctld still answers), then stops slurmd, slurmctld
#            and munged by the PIDs recorded in DIR: SIGTERM, then SIGKILL after RESTIR_SLURM_STOP_TIMEOUT
#            (default 15 s), waiting until each has exited. A PID is only signalled if that process's command line
#            names DIR (so a reused PID is never hit); no process is looked up or killed by name. Idempotent.
#
# Ports: slurmctld listens on RESTIR_SLURMCTLD_PORT (default 16817), slurmd on RESTIR_SLURMD_PORT (default
# 16818). Only one cluster per port pair can run: `start` refuses, with a message, when either port is taken
# (e.g. by a cluster started in another DIR); give a second cluster other ports to run both.
# RESTIR_SLURM_MIN_JOB_AGE (default 4) is slurm.conf's MinJobAge: see the note in the slurm.conf below.
# Nothing system-wide is used or touched: no /etc/munge, /run/munge, /etc/slurm, /var/spool/slurm*.
# munged logs "Unauthorized credential for client UID=0" once per slurm daemon and job start: Slurm checks on
# purpose that a credential restricted to another UID cannot be decoded. The PMIx errors in the Slurm logs come
# from the mpi/pmix plugins (libpmix is not installed); MpiDefault=none does not use them.
set -euo pipefail

prog=$(basename "$0")
usage() {
  echo "usage: $prog start DIR | $prog stop DIR" >&2
  exit 2
}
log() { echo "$prog: $*" >&2; }

[[ $# -eq 2 ]] || usage
action=$1
[[ -n $2 ]] || usage
dir=$(realpath -m -- "$2")

ctld_port=${RESTIR_SLURMCTLD_PORT:-16817}
slurmd_port=${RESTIR_SLURMD_PORT:-16818}
start_timeout=${RESTIR_SLURM_START_TIMEOUT:-60}
stop_timeout=${RESTIR_SLURM_STOP_TIMEOUT:-15}
min_job_age=${RESTIR_SLURM_MIN_JOB_AGE:-4}
conf=$dir/slurm.conf
munge_dir=$dir/munge
munge_socket=$munge_dir/munge.socket.2
daemons_stop_order=(slurmd slurmctld munged)

# The PID recorded for daemon $1 if that process is alive (not a zombie) and its command line names $dir.
live_pid() {
  local pidfile=$dir/$1.pid pid state cmdline
  [[ -f $pidfile ]] || return 1
  pid=$(<"$pidfile") || return 1
  [[ $pid =~ ^[0-9]+$ ]] || return 1
  state=$(awk '{ sub(/^.*\) /, ""); print $1 }' "/proc/$pid/stat" 2>/dev/null) || return 1
  [[ -n $state && $state != Z && $state != X ]] || return 1
  cmdline=$(tr '\0' ' ' <"/proc/$pid/cmdline" 2>/dev/null) || return 1
  [[ $cmdline == *"$dir/"* ]] || return 1
  echo "$pid"
}

# Waits up to $2 seconds for process $1 to exit (a zombie counts as exited: its parent may reap it late).
wait_exit() {
  local pid=$1 deadline=$((SECONDS + $2 + 1)) state   # + 1: SECONDS counts whole seconds
  while ((SECONDS < deadline)); do
    state=$(awk '{ sub(/^.*\) /, ""); print $1 }' "/proc/$pid/stat" 2>/dev/null) || return 0
    [[ -z $state || $state == Z || $state == X ]] && return 0
    sleep 0.1
  done
  return 1
}

stop_daemon() {
  local name=$1 pid
  if pid=$(live_pid "$name"); then
    log "stopping $name (pid $pid)"
    kill -TERM "$pid" 2>/dev/null || true
    if ! wait_exit "$pid" "$stop_timeout"; then
      log "$name (pid $pid) still running after ${stop_timeout}s: SIGKILL"
      kill -KILL "$pid" 2>/dev/null || true
      wait_exit "$pid" 10 || { log "error: $name (pid $pid) survived SIGKILL"; return 1; }
    fi
  fi
  rm -f "$dir/$name.pid"
}

# Cancels whatever jobs the cluster still has, so that no slurmstepd (and job) outlives its slurmd.
cancel_jobs() {
  live_pid slurmctld >/dev/null || return 0
  local ids=() deadline
  mapfile -t ids < <(SLURM_CONF=$conf timeout 10 squeue -h -o %i 2>/dev/null || true)
  ((${#ids[@]})) || return 0
  log "cancelling remaining jobs: ${ids[*]}"
  SLURM_CONF=$conf timeout 10 scancel "${ids[@]}" >&2 || true
  deadline=$((SECONDS + 20))
  while ((SECONDS < deadline)); do
    [[ -z $(SLURM_CONF=$conf timeout 10 squeue -h -o %i 2>/dev/null) ]] && return 0
    sleep 0.5
  done
  log "warning: jobs still listed by squeue 20s after scancel"
}

do_stop() {
  local rc=0 name
  [[ -d $dir ]] || return 0
  [[ -f $conf ]] && cancel_jobs
  for name in "${daemons_stop_order[@]}"; do
    stop_daemon "$name" || rc=1
  done
  rm -f "$munge_socket" "$munge_socket.lock"
  return $rc
}

port_in_use() {
  timeout 3 bash -c "exec 3<>/dev/tcp/127.0.0.1/$1" 2>/dev/null
}

# The daemons' stdout/stderr: munged --foreground logs there only, slurmctld -D and slurmd -D copy their log
# files there and add what they print before opening them (bad slurm.conf, say).
show_logs() {
  local name f
  for name in munged slurmctld slurmd; do
    f=$dir/$name.out
    [[ -s $f ]] || continue
    echo "---- last lines of $f ----" >&2
    tail -n 20 "$f" >&2
  done
}

fail() {
  log "error: $*"
  show_logs
  log "stopping what was started"
  do_stop || true
  exit 1
}

# Starts daemon $1 (the rest is its command line, which must not fork) in a session of its own, with its
# stdout/stderr in DIR/$1.out, and records its PID in DIR/$1.pid. Fails if it exits at once.
launch() {
  local name=$1 pid
  shift
  (
    # Close every inherited descriptor above stderr: a caller's pipe kept open by a daemon would make it wait.
    for fd in /proc/self/fd/*; do
      fd=${fd##*/}
      if ((fd > 2)); then eval "exec $fd>&-" 2>/dev/null || true; fi
    done
    exec setsid "$@"
  ) </dev/null >>"$dir/$name.out" 2>&1 &
  pid=$!
  echo "$pid" >"$dir/$name.pid"
  sleep 0.2
  live_pid "$name" >/dev/null || { log "$name (pid $pid) exited at once"; return 1; }
  log "started $name (pid $pid)"
}

do_start() {
  [[ $EUID -eq 0 ]] || { log "error: must run as root"; exit 1; }
  local cmd name pid
  for cmd in munged mungekey munge unmunge slurmctld slurmd sinfo; do
    command -v "$cmd" >/dev/null || PATH=$PATH:/usr/sbin:/sbin
    command -v "$cmd" >/dev/null || { log "error: $cmd not found (apt-get install munge slurmctld slurmd slurm-client)"; exit 1; }
  done
  for name in "${daemons_stop_order[@]}"; do
    if pid=$(live_pid "$name"); then
      log "error: a cluster is already running in $dir ($name pid $pid); run '$prog stop $dir' first"
      exit 1
    fi
  done
  local p
  [[ $ctld_port =~ ^[0-9]+$ && $slurmd_port =~ ^[0-9]+$ && $ctld_port != "$slurmd_port" ]] ||
    { log "error: ports '$ctld_port' (slurmctld) and '$slurmd_port' (slurmd) must be two different numbers"; exit 1; }
  for p in "$ctld_port" "$slurmd_port"; do
    if port_in_use "$p"; then
      log "error: port $p on 127.0.0.1 is already in use (another local cluster still running?);" \
        "stop it, or set RESTIR_SLURMCTLD_PORT / RESTIR_SLURMD_PORT to free ports"
      exit 1
    fi
  done

  local node cpus t0=$SECONDS
  node=$(hostname -s)
  cpus=$(nproc)
  mkdir -p "$dir" "$munge_dir" "$dir/state" "$dir/spool"
  chmod 0755 "$dir" "$munge_dir"   # munged refuses group/world-writable dirs; 0755 lets any user reach the socket
  # A clean start: forget the previous run's daemons' leftovers (logs are kept, appended to).
  rm -f "$dir"/{munged,slurmctld,slurmd}.pid "$munge_socket" "$munge_socket.lock"
  rm -rf "${dir:?}/state/"* "${dir:?}/spool/"*

  log "writing $conf (node $node, $cpus CPUs, ports $ctld_port/$slurmd_port)"
  cat >"$conf" <<EOF
# Private single-node test cluster written by scripts/slurm/local_cluster.sh; stop it with
#   scripts/slurm/local_cluster.sh stop $dir
ClusterName=restirtest
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root

# Authentication and job credentials through this cluster's own munged.
AuthType=auth/munge
AuthInfo=socket=$munge_socket
CredType=cred/munge

PlugStackConfig=$dir/plugstack.conf
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info

# No cgroups: processes tracked through /proc, no task binding (no cgroup.conf needed).
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none

# Per-CPU scheduling: 1-CPU tasks share the node.
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU

# No accounting daemon: finished jobs are listed in a plain file (JobState, ExitCode). slurmctld forgets a
# finished job MinJobAge s after it ended, at its next purge (about once a minute); sbatch --wait polls every
# 2 s only while MinJobAge <= 4 (else 2, 8, 32 s backoff).
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/filetxt
JobCompLoc=$dir/jobcomp.log
MinJobAge=$min_job_age

ReturnToService=2
MailProg=/bin/true
KillWait=5
InactiveLimit=0

NodeName=$node NodeAddr=127.0.0.1 NodeHostname=$node CPUs=$cpus State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF

  echo "# no SPANK plugins (written by local_cluster.sh)" >"$dir/plugstack.conf"

  trap 'fail "interrupted"' INT TERM
  log "creating munge key"
  rm -f "$munge_dir/munge.key"
  mungekey --create --keyfile="$munge_dir/munge.key" >&2 2>&1 || fail "mungekey failed"
  chmod 0400 "$munge_dir/munge.key"

  # In the foreground munged logs to stderr (DIR/munged.out), not to --log-file.
  local munged_args=(munged --foreground --socket="$munge_socket" --key-file="$munge_dir/munge.key"
    --pid-file="$dir/munged.pid" --log-file="$munge_dir/munged.log" --seed-file="$munge_dir/munged.seed")
  # munged checks the directories above its files: one that is group/world-writable without the sticky bit, or
  # owned by another user (a test's temp dir, say), is an error unless --force turns it into a warning. --force
  # is only added when that happens, since it also lets munged take over a socket another munged is bound to.
  local deadline
  launch munged "${munged_args[@]}" || true
  deadline=$((SECONDS + 15))
  until munge -n -S "$munge_socket" 2>/dev/null | unmunge -S "$munge_socket" >/dev/null 2>&1; do
    if ! live_pid munged >/dev/null; then
      if [[ ${munged_args[-1]} != --force ]] && grep -qiE 'insecure|ownership|permission' "$dir/munged.out"; then
        log "munged refused the permissions of a directory above $dir ($(grep -iE 'insecure|ownership|permission' \
          "$dir/munged.out" | tail -n 1)); retrying with --force"
        munged_args+=(--force)
        launch munged "${munged_args[@]}" || fail "munged exited"
        continue
      fi
      fail "munged exited"
    fi
    ((SECONDS < deadline)) || fail "munged does not answer on $munge_socket"
    sleep 0.1
  done

  launch slurmctld slurmctld -D -c -f "$conf" || fail "slurmctld exited"
  launch slurmd slurmd -D -f "$conf" -N "$node" || fail "slurmd exited"

  log "waiting (up to ${start_timeout}s) for node $node to be idle"
  local state=""
  deadline=$((SECONDS + start_timeout))
  while :; do
    for name in munged slurmctld slurmd; do
      live_pid "$name" >/dev/null || fail "$name exited"
    done
    state=$(SLURM_CONF=$conf timeout 10 sinfo -h -N -n "$node" -o %T 2>/dev/null || true)
    [[ $state == idle ]] && break
    ((SECONDS < deadline)) || fail "node $node not idle after ${start_timeout}s (sinfo says '${state:-nothing}')"
    sleep 0.5
  done
  trap - INT TERM
  log "cluster up in $((SECONDS - t0))s: node $node idle, $cpus CPUs, partition debug"
  printf 'export SLURM_CONF=%q\n' "$conf"
}

case $action in
  start) do_start ;;
  stop)
    do_stop || { log "error: some daemon could not be stopped"; exit 1; }
    log "stopped (or was not running): $dir"
    ;;
  *) usage ;;
esac
