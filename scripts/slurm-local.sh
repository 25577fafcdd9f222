#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for the tests and for trying array jobs
# (`fluid-lab slurm`) without a cluster. Debian's slurm-wlm and munge packages; run as root.
#
# Usage: scripts/slurm-local.sh start|stop|status [DIR]
#   start   writes DIR/slurm.conf (one node: this host, its CPUs and memory), starts munged
#           (as user munge, unless one already answers), slurmctld and slurmd, and waits
#           until the node takes jobs; prints the line to source: export SLURM_CONF=...
#   stop    stops the daemons it started (pid files in DIR); munged is left to its owner
#   status  exits 0 if the cluster answers, and prints sinfo's view of it
#   DIR     the cluster's folder: configuration, spool, logs, pid files
#           (default: target/slurm-local in this checkout)
# Clients (sbatch, squeue, fluid-lab slurm) find the cluster through SLURM_CONF; nothing
# is written to /etc/slurm, so a machine's own Slurm configuration is never touched.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
action="${1:-}"
dir="${2:-$root/target/slurm-local}"
mkdir -p "$dir"
dir="$(cd "$dir" && pwd)"
conf="$dir/slurm.conf"
export SLURM_CONF="$conf"

fail() {
    echo "slurm-local: $*" >&2
    exit 1
}

answers() {
    timeout 5 sinfo --noheader --format=%T 2>/dev/null | grep -qE '^(idle|mixed|allocated)'
}

write_conf() {
    local node cpus memory
    node="$(hostname -s)"
    cpus="$(nproc --all)"
    memory="$(awk '/^MemTotal:/ { print int($2 / 1024) }' /proc/meminfo)"
    mkdir -p "$dir/spool/ctld" "$dir/spool/d" "$dir/log"
    cat >"$conf" <<EOF
# Written by scripts/slurm-local.sh: a one-node cluster on $node.
ClusterName=fluid-local
SlurmctldHost=$node
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=$dir/spool/ctld
SlurmdSpoolDir=$dir/spool/d
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/backfill
JobAcctGatherType=jobacct_gather/linux
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
SlurmdTimeout=60
InactiveLimit=0
MinJobAge=300
MaxArraySize=10001
NodeName=$node CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
}

start_munge() {
    if munge -n </dev/null 2>/dev/null | unmunge >/dev/null 2>&1; then
        return
    fi
    mkdir -p /run/munge
    chown munge:munge /run/munge
    chmod 0755 /run/munge
    [ -f /etc/munge/munge.key ] || fail "no /etc/munge/munge.key (install the munge package)"
    runuser -u munge -- /usr/sbin/munged
    for _ in $(seq 50); do
        munge -n </dev/null 2>/dev/null | unmunge >/dev/null 2>&1 && return
        sleep 0.1
    done
    fail "munged did not answer"
}

running() {
    local pidfile="$dir/$1.pid"
    [ -f "$pidfile" ] && kill -0 "$(cat "$pidfile")" 2>/dev/null
}

case "$action" in
    start)
        [ "$(id -u)" -eq 0 ] || fail "start needs root (munged, slurmctld and slurmd)"
        for program in munged slurmctld slurmd sinfo sbatch; do
            command -v "$program" >/dev/null || [ -x "/usr/sbin/$program" ] \
                || fail "no $program: apt-get install slurm-wlm munge"
        done
        if answers; then
            echo "export SLURM_CONF=$conf"
            exit 0
        fi
        write_conf
        start_munge
        running slurmctld || /usr/sbin/slurmctld -f "$conf"
        running slurmd || /usr/sbin/slurmd -f "$conf"
        for _ in $(seq 100); do
            if answers; then
                echo "export SLURM_CONF=$conf"
                exit 0
            fi
            sleep 0.2
        done
        tail -n 5 "$dir/log/slurmctld.log" "$dir/log/slurmd.log" >&2 || true
        fail "the node did not become idle within 20 s (logs in $dir/log)"
        ;;
    stop)
        for daemon in slurmd slurmctld; do
            if running "$daemon"; then
                kill "$(cat "$dir/$daemon.pid")"
                for _ in $(seq 50); do
                    running "$daemon" || break
                    sleep 0.1
                done
            fi
        done
        echo "stopped the cluster of $dir"
        ;;
    status)
        answers || fail "no cluster answers at $conf"
        sinfo
        ;;
    *)
        fail "usage: scripts/slurm-local.sh start|stop|status [DIR]"
        ;;
esac
