#!/usr/bin/env bash
# A single-node SLURM cluster on this machine (Debian/Ubuntu, run as root), to try
# `snakemake --profile profiles/slurm` without a real cluster.
#
#   workflow/cluster/local-slurm.sh          # install (once), configure, start, wait for the node
#   workflow/cluster/local-slurm.sh status   # sinfo + squeue
#   workflow/cluster/local-slurm.sh stop     # stop slurmd, slurmctld and munged
#
# Rerunnable: packages are installed only when missing, the configuration is
# rewritten, and daemons already running are restarted so they read it.
# No systemd needed: munged, slurmctld and slurmd are started directly.
#
# What the cluster is:
#   one node (this host's short name) with all its CPUs and its memory minus
#   SLURM_HEADROOM_MB (default 2048), one partition named $SLURM_PARTITION
#   (default "local"); select/cons_tres with CR_Core_Memory so --mem and
#   --cpus-per-task are enforced by the scheduler; proctrack/linuxproc and
#   task/none because containers usually have no writable cgroup hierarchy;
#   the daemons talk over 127.0.0.1, so the host name need not resolve.
#   There is no slurmdbd (accounting_storage/none): `sacct` cannot answer, so the
#   executor plugin must query job states with squeue
#   (`--slurm-status-command squeue`); MinJobAge is raised so finished jobs stay
#   visible to squeue long enough.  Without slurmdbd any account name is accepted.
set -euo pipefail

PARTITION=${SLURM_PARTITION:-local}
HEADROOM_MB=${SLURM_HEADROOM_MB:-2048}
CONF_DIR=/etc/slurm
LOG_DIR=/var/log/slurm
STATE_DIR=/var/lib/slurm/slurmctld
SPOOL_DIR=/var/spool/slurmd
NODE=$(hostname -s)

log() { printf '[local-slurm] %s\n' "$*"; }

need_root() {
    if [ "$(id -u)" -ne 0 ]; then
        echo "local-slurm.sh must run as root" >&2
        exit 1
    fi
}

# pid of a daemon from its pid file, if that process is alive
alive_pid() {
    local pidfile=$1
    if [ -s "$pidfile" ] && kill -0 "$(cat "$pidfile")" 2>/dev/null; then
        cat "$pidfile"
    fi
}

stop_daemon() {
    local name=$1 pidfile=$2 pid
    pid=$(alive_pid "$pidfile")
    if [ -n "$pid" ]; then
        log "stopping $name (pid $pid)"
        kill "$pid"
        for _ in $(seq 1 50); do
            kill -0 "$pid" 2>/dev/null || break
            sleep 0.2
        done
        if kill -0 "$pid" 2>/dev/null; then
            log "$name did not stop, sending SIGKILL"
            kill -9 "$pid" || true
        fi
    fi
    rm -f "$pidfile"
}

stop_all() {
    stop_daemon slurmd /run/slurmd.pid
    stop_daemon slurmctld /run/slurmctld.pid
    stop_daemon munged /run/munge/munged.pid
}

install_packages() {
    if command -v slurmctld >/dev/null && command -v slurmd >/dev/null \
            && command -v munged >/dev/null && command -v sinfo >/dev/null; then
        log "slurm-wlm and munge already installed"
        return
    fi
    log "installing slurm-wlm and munge"
    export DEBIAN_FRONTEND=noninteractive
    # a fresh container has no package lists
    if ! apt-cache show slurm-wlm >/dev/null 2>&1; then
        apt-get update -q
    fi
    apt-get install -y -q --no-install-recommends slurm-wlm munge
}

write_config() {
    local cpus mem_total real_mem
    cpus=$(nproc --all)
    mem_total=$(free -m | awk '/^Mem:/ {print $2}')
    real_mem=$((mem_total - HEADROOM_MB))
    if [ "$real_mem" -lt 1024 ]; then
        real_mem=$((mem_total / 2))
    fi
    mkdir -p "$CONF_DIR" "$LOG_DIR" "$STATE_DIR" "$SPOOL_DIR"
    log "writing $CONF_DIR/slurm.conf: node $NODE, CPUs=$cpus, RealMemory=$real_mem MB, partition $PARTITION"
    cat > "$CONF_DIR/slurm.conf" <<EOF
# Written by fracfem's workflow/cluster/local-slurm.sh (rerun it to regenerate).
ClusterName=localcluster
SlurmctldHost=$NODE(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
# no cgroups in a container: track processes through /proc, no task binding
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/backfill
ReturnToService=2
# no slurmdbd: job states come from slurmctld (squeue), kept 20 min after the end
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/linux
JobCompType=jobcomp/none
MinJobAge=1200
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=$LOG_DIR/slurmctld.log
SlurmdLogFile=$LOG_DIR/slurmd.log
StateSaveLocation=$STATE_DIR
SlurmdSpoolDir=$SPOOL_DIR
SlurmctldTimeout=60
SlurmdTimeout=60
NodeName=$NODE NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$real_mem State=UNKNOWN
PartitionName=$PARTITION Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
EOF
    # slurmd reads cgroup.conf at start when present; an empty one is not needed
}

start_munge() {
    if [ -n "$(alive_pid /run/munge/munged.pid)" ]; then
        log "munged running"
        return
    fi
    mkdir -p /run/munge /var/log/munge /var/lib/munge
    chown munge:munge /run/munge /var/log/munge /var/lib/munge
    chmod 0755 /run/munge
    if [ ! -s /etc/munge/munge.key ]; then
        log "creating /etc/munge/munge.key"
        mungekey --create --keyfile=/etc/munge/munge.key
    fi
    chown munge:munge /etc/munge/munge.key
    chmod 0400 /etc/munge/munge.key
    log "starting munged"
    runuser -u munge -- /usr/sbin/munged
    for _ in $(seq 1 50); do
        munge -n 2>/dev/null | unmunge >/dev/null 2>&1 && return
        sleep 0.2
    done
    echo "munged does not answer (see /var/log/munge/munged.log)" >&2
    exit 1
}

start_slurm() {
    # restart so that both daemons read the configuration just written
    stop_daemon slurmd /run/slurmd.pid
    stop_daemon slurmctld /run/slurmctld.pid
    log "starting slurmctld"
    slurmctld
    for _ in $(seq 1 50); do
        scontrol ping 2>/dev/null | grep -q UP && break
        sleep 0.2
    done
    if ! scontrol ping 2>/dev/null | grep -q UP; then
        echo "slurmctld does not answer; last lines of $LOG_DIR/slurmctld.log:" >&2
        tail -n 20 "$LOG_DIR/slurmctld.log" >&2 || true
        exit 1
    fi
    log "starting slurmd"
    slurmd
}

wait_idle() {
    local state
    for _ in $(seq 1 60); do
        state=$(sinfo -h -N -n "$NODE" -o '%T' 2>/dev/null || true)
        case "$state" in
            idle|mixed|allocated)
                log "node $NODE is $state"
                sinfo
                return ;;
            down*|drain*|fail*)
                # a restarted node may come back down ("Node unexpectedly rebooted")
                scontrol update NodeName="$NODE" State=RESUME 2>/dev/null || true ;;
        esac
        sleep 1
    done
    echo "node $NODE not idle after 60 s (state: ${state:-unknown}); last lines of the logs:" >&2
    tail -n 20 "$LOG_DIR/slurmd.log" "$LOG_DIR/slurmctld.log" >&2 || true
    exit 1
}

main() {
    need_root
    case "${1:-start}" in
        start)
            install_packages
            write_config
            start_munge
            start_slurm
            wait_idle ;;
        stop)
            stop_all ;;
        status)
            sinfo
            squeue --states=all ;;
        *)
            echo "usage: $0 [start|stop|status]" >&2
            exit 2 ;;
    esac
}

main "$@"
