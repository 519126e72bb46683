#!/usr/bin/env bash
# A single-host Slurm cluster on loopback, for nimbus's farm test (tests/farm) and for trying
# `nimbus farm submit --engine slurm` on one machine. Debian's slurm-wlm and munge.
#
#   scripts/slurm-local.sh install  install slurm-wlm and munge from Debian if missing (exit 3
#                                   when apt cannot install them: no network, no Debian)
#   scripts/slurm-local.sh start    install (if missing), write the config, start munged,
#                                   slurmctld and slurmd (those not running), wait until the node
#                                   is idle
#   scripts/slurm-local.sh stop     stop the daemons `start` started, by their process ids (kept
#                                   in /run/slurm-local.started), and wait until they are gone;
#                                   daemons it found running are left alone
#   scripts/slurm-local.sh status   sinfo, or exit 1 when the cluster does not answer
#
# Root only (the daemons run as root here; a real farm has its own Slurm). The configuration
# is written to /etc/slurm/slurm.conf only when that file is absent or was written by this
# script, so an existing cluster's configuration is never replaced. One node, named after the
# host, with every CPU; process tracking by /proc (no cgroups needed, so it runs in containers).
set -euo pipefail

conf=/etc/slurm/slurm.conf
marker="# written by nimbus scripts/slurm-local.sh"
log_dir=/var/log/slurm-local
state_dir=/var/spool/slurm-local
started=/run/slurm-local.started  # "<pid> <name>" of each daemon start started

need_root() {
  if [ "$(id -u)" -ne 0 ]; then
    echo "slurm-local: must run as root (it starts munged, slurmctld and slurmd)" >&2
    exit 2
  fi
}

install_packages() {
  local missing=()
  for p in slurm-wlm munge; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "slurm-local: installing ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    if ! command -v apt-get >/dev/null; then
      echo "slurm-local: cannot install ${missing[*]}: no apt-get (not Debian)" >&2
      exit 3
    fi
    if ! { apt-get update -qq && apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null; }; then
      echo "slurm-local: cannot install ${missing[*]} with apt-get (no network or no package source?)" >&2
      exit 3
    fi
  fi
}

write_config() {
  if [ -f "$conf" ] && ! grep -qF "$marker" "$conf"; then
    echo "slurm-local: $conf exists and was not written by this script; using it as it is"
    return
  fi
  local host cpus mem
  host=$(hostname -s)
  cpus=$(nproc)
  mem=$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)
  mkdir -p "$log_dir" "$state_dir/ctld" "$state_dir/d" /etc/slurm
  cat >"$conf" <<EOF
$marker
ClusterName=nimbus-local
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$state_dir/ctld
SlurmdSpoolDir=$state_dir/d
SlurmctldPidFile=/run/slurmctld-local.pid
SlurmdPidFile=/run/slurmd-local.pid
SlurmctldLogFile=$log_dir/slurmctld.log
SlurmdLogFile=$log_dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
ReturnToService=2
JobRequeue=1
MaxArraySize=100001
KillWait=5
MinJobAge=600
SlurmdTimeout=60
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
EOF
}

# A daemon is running when its pid file names a live process that is not a zombie.
running() {
  local pid
  pid=$(cat "$1" 2>/dev/null) || return 1
  [ -n "$pid" ] && [ -d "/proc/$pid" ] && ! grep -q '^State:.*Z' "/proc/$pid/status" 2>/dev/null
}

# Waits up to 10 s for the pid file a daemon writes once it has detached, then records the pid.
record() {
  local pidfile=$1 name=$2 pid=""
  for _ in $(seq 1 100); do
    pid=$(cat "$pidfile" 2>/dev/null || true)
    [ -n "$pid" ] && [ -d "/proc/$pid" ] && break
    sleep 0.1
  done
  if [ -z "$pid" ] || [ ! -d "/proc/$pid" ]; then
    echo "slurm-local: $name did not start (no live pid in $pidfile; logs in $log_dir)" >&2
    exit 1
  fi
  echo "$pid $name" >>"$started"
}

start() {
  need_root
  install_packages
  write_config
  mkdir -p /run/munge /var/log/munge /var/lib/munge
  chown munge:munge /run/munge /var/log/munge /var/lib/munge 2>/dev/null || true
  if [ ! -s /etc/munge/munge.key ]; then
    /usr/sbin/mungekey --create --force >/dev/null 2>&1 || dd if=/dev/urandom of=/etc/munge/munge.key bs=128 count=1 2>/dev/null
    chown munge:munge /etc/munge/munge.key
    chmod 600 /etc/munge/munge.key
  fi
  if ! munge -n </dev/null >/dev/null 2>&1; then
    # munged refuses to run as root; the Debian package's user owns its key and sockets.
    rm -f /run/munge/munged.pid
    su -s /bin/sh munge -c /usr/sbin/munged 2>/dev/null || /usr/sbin/munged --force
    record /run/munge/munged.pid munged
  fi
  if ! running /run/slurmctld-local.pid; then
    rm -f /run/slurmctld-local.pid
    /usr/sbin/slurmctld
    record /run/slurmctld-local.pid slurmctld
  fi
  if ! running /run/slurmd-local.pid; then
    rm -f /run/slurmd-local.pid
    /usr/sbin/slurmd
    record /run/slurmd-local.pid slurmd
  fi
  local host
  host=$(hostname -s)
  for _ in $(seq 1 60); do
    state=$(sinfo -h -n "$host" -o %T 2>/dev/null || true)
    case "$state" in
      *"*") ;;  # not responding yet
      idle | mixed | allocated) echo "slurm-local: node $host $state"; return 0 ;;
      down* | drain*) scontrol update NodeName="$host" State=RESUME >/dev/null 2>&1 || true ;;
    esac
    sleep 1
  done
  echo "slurm-local: the node did not come up (logs in $log_dir)" >&2
  exit 1
}

# Is `pid` still the daemon `name` (not a later process that reused the number)?
alive() {
  [ -d "/proc/$1" ] && [ "$(cat "/proc/$1/comm" 2>/dev/null)" = "$2" ] &&
    ! grep -q '^State:.*Z' "/proc/$1/status" 2>/dev/null
}

stop() {
  need_root
  [ -f "$started" ] || { echo "slurm-local: nothing started by this script is running"; return 0; }
  local pid name left
  # slurmd first, munged last: the daemons shut down cleanly while they can still authenticate.
  for daemon in slurmd slurmctld munged; do
    while read -r pid name; do
      [ "$name" = "$daemon" ] && alive "$pid" "$name" && kill -TERM "$pid" 2>/dev/null || true
    done <"$started"
  done
  for _ in $(seq 1 100); do
    left=""
    while read -r pid name; do
      alive "$pid" "$name" && left="$left $name($pid)"
    done <"$started"
    [ -z "$left" ] && break
    sleep 0.1
  done
  if [ -n "$left" ]; then
    echo "slurm-local: still running after 10 s:$left; sending SIGKILL" >&2
    while read -r pid name; do
      alive "$pid" "$name" && kill -KILL "$pid" 2>/dev/null || true
    done <"$started"
  fi
  rm -f "$started"
  echo "slurm-local: stopped"
}

case "${1:-}" in
  install) need_root; install_packages ;;
  start) start ;;
  stop) stop ;;
  status) sinfo ;;
  *) echo "usage: $0 install|start|stop|status" >&2; exit 2 ;;
esac
