#!/usr/bin/env bash
# A one-node Slurm cluster on this machine for the farm tests: `slurm-local.sh start` writes a
# slurm.conf for localhost with this machine's CPUs and memory, starts munged, slurmctld and slurmd,
# and waits until sinfo reports the node idle; `slurm-local.sh stop` stops the daemons. Root only
# (the daemons run as root, state under $SLURM_STATE, default /tmp/farm-slurm).
set -euo pipefail
state=${SLURM_STATE:-/tmp/farm-slurm}
conf=/etc/slurm/slurm.conf
case "${1:-}" in
start)
    command -v slurmctld >/dev/null || { echo "slurm-local: slurm-wlm is not installed" >&2; exit 1; }
    mkdir -p "$state"/{ctld,d,log} /etc/slurm /run/munge /var/log/munge /var/lib/munge /etc/munge
    node=$(hostname -s)
    # CPUs and memory as slurmd sees them (its -C line), so the node registers without a mismatch.
    hw=$(slurmd -C | head -1 | sed "s/^NodeName=[^ ]*//")
    cat > "$conf" <<CONF
ClusterName=farmtest
SlurmctldHost=$node
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/d
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/log/slurmctld.log
SlurmdLogFile=$state/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
MinJobAge=30
KillWait=5
NodeName=$node$hw State=UNKNOWN
PartitionName=farm Nodes=$node Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
CONF
    [ -s /etc/munge/munge.key ] || { dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key 2>/dev/null; }
    chown -R munge:munge /etc/munge /run/munge /var/log/munge /var/lib/munge 2>/dev/null || true
    chmod 0400 /etc/munge/munge.key
    pgrep -x munged >/dev/null || runuser -u munge -- /usr/sbin/munged || /usr/sbin/munged --force
    pgrep -x slurmctld >/dev/null || slurmctld -i
    pgrep -x slurmd >/dev/null || slurmd
    for _ in $(seq 60); do
        if sinfo -h -o %t 2>/dev/null | grep -qx idle; then echo "slurm-local: node $node idle"; exit 0; fi
        sleep 1
    done
    echo "slurm-local: the node did not become idle; sinfo says: $(sinfo 2>&1)" >&2
    tail -5 "$state"/log/*.log >&2 || true
    exit 1
    ;;
stop)
    pkill -x slurmd || true
    pkill -x slurmctld || true
    pkill -x munged || true
    ;;
*) echo "usage: $0 start|stop" >&2; exit 2 ;;
esac
