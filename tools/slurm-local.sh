#!/usr/bin/env bash
# A one-node SLURM on localhost, for testing `verify sweep --emit slurm` against a real scheduler.
#   bash tools/slurm-local.sh start STATE_DIR   # munge + slurmctld + slurmd; waits for the node
#   bash tools/slurm-local.sh stop STATE_DIR    # stops the daemons it started (by pid file)
# Needs root and Debian's slurmctld, slurmd, slurm-client, munge (CI installs them). Writes
# /etc/slurm/slurm.conf (the daemons and sbatch read it there) and, if missing,
# /etc/munge/munge.key (a slurm.conf that was there is restored by stop). Everything else
# lives in STATE_DIR.
set -euo pipefail
cmd="${1:?start|stop}"; state="${2:?state dir}"
mkdir -p "$state"
state="$(cd "$state" && pwd)"
case "$cmd" in
start)
  for b in munged slurmctld slurmd sinfo sbatch; do
    command -v "$b" >/dev/null || { echo "missing $b: apt-get install -y slurmctld slurmd slurm-client munge" >&2; exit 2; }
  done
  if [ ! -s /etc/munge/munge.key ]; then
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
  fi
  chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
  mkdir -p /run/munge /var/log/munge /var/lib/munge && chown munge:munge /run/munge /var/log/munge /var/lib/munge
  if ! pgrep -x munged >/dev/null; then
    su -s /bin/sh munge -c "munged --pid-file=/run/munge/munged.pid" && cp /run/munge/munged.pid "$state/munged.pid"
  fi
  mkdir -p "$state/spool/ctld" "$state/spool/d" "$state/log"
  host="$(hostname -s)"
  mkdir -p /etc/slurm
  if [ -f /etc/slurm/slurm.conf ] && ! grep -q "^# written by dem-verify" /etc/slurm/slurm.conf; then
    cp /etc/slurm/slurm.conf "$state/slurm.conf.orig"   # restored by stop
  fi
  cat > /etc/slurm/slurm.conf <<CONF
# written by dem-verify tools/slurm-local.sh
ClusterName=local
SlurmctldHost=$host
SlurmUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
SchedulerType=sched/backfill
StateSaveLocation=$state/spool/ctld
SlurmdSpoolDir=$state/spool/d
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/log/slurmctld.log
SlurmdLogFile=$state/log/slurmd.log
JobCompType=jobcomp/none
NodeName=$host CPUs=$(nproc) State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
  slurmctld -c
  slurmd
  for _ in $(seq 60); do
    if sinfo -h -o %t 2>/dev/null | grep -Eq '^(idle|mix|alloc)'; then sinfo; exit 0; fi
    sleep 1
  done
  echo "the local SLURM node did not become idle; logs in $state/log" >&2
  sinfo >&2 || true
  tail -n 20 "$state/log/"*.log >&2 || true
  exit 2
  ;;
stop)
  for d in slurmd slurmctld munged; do
    if [ -s "$state/$d.pid" ]; then kill "$(cat "$state/$d.pid")" 2>/dev/null || true; fi
  done
  if [ -f "$state/slurm.conf.orig" ]; then cp "$state/slurm.conf.orig" /etc/slurm/slurm.conf; fi
  ;;
*) echo "usage: $0 start|stop STATE_DIR" >&2; exit 2 ;;
esac
