#!/usr/bin/env bash
# A single-node Slurm cluster on this machine, to try `plsr farm slurm`
# without a real cluster (docs/farm.md). It needs Debian's slurm-wlm and
# munge (`make test-deps` installs them) and runs as the current user: no
# root, no system configuration touched. Everything lives in DIR.
#
#   bash scripts/slurm-single-node.sh start DIR   configures and starts munged,
#                                                 slurmctld and slurmd; waits
#                                                 until the node is idle
#   export SLURM_CONF=DIR/slurm.conf              then sbatch, squeue, plsr farm
#                                                 slurm --submit … use it
#   bash scripts/slurm-single-node.sh stop DIR    stops the daemons (DIR stays)
#
# A daemon that does not start, or a node that is not idle within 60 s,
# ends `start` with status 1 and the daemons' logs. The test suite runs
# its Slurm test on a cluster this script starts (crates/cli/tests/it/slurm.rs).
set -euo pipefail

usage() {
    echo "usage: $0 start DIR | stop DIR" >&2
    exit 2
}
[ $# -eq 2 ] || usage
action="$1"
dir="$2"

# A daemon, on PATH or in the sbin folders.
program() {
    local p
    for p in "$(command -v "$1" 2>/dev/null || true)" "/usr/sbin/$1" "/sbin/$1" "/usr/local/sbin/$1"; do
        if [ -n "$p" ] && [ -x "$p" ]; then
            echo "$p"
            return
        fi
    done
    echo "$0: $1 is not installed: install Debian's slurm-wlm and munge (make test-deps)" >&2
    exit 1
}

# A TCP port nobody listens on now.
free_port() {
    local port
    while :; do
        port=$((20000 + RANDOM % 40000))
        if ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then
            echo "$port"
            return
        fi
    done
}

logs() {
    local log
    for log in munge/munged.log slurmctld.log slurmd.log; do
        echo "--- $dir/$log ---" >&2
        cat "$dir/$log" >&2 2>/dev/null || echo "(none)" >&2
    done
}

fail() {
    echo "$0: $1" >&2
    logs
    exit 1
}

start() {
    local munged slurmctld slurmd
    munged=$(program munged)
    slurmctld=$(program slurmctld)
    slurmd=$(program slurmd)
    program sbatch > /dev/null
    mkdir -p "$dir"/{state,spool,munge,munge-key}
    dir=$(cd "$dir" && pwd)
    # munged wants its socket's folders searchable by everyone, and its key
    # (1 KiB of random bytes) in a folder of its owner's alone.
    chmod 755 "$dir" "$dir/munge"
    chmod 700 "$dir/munge-key"
    local key="$dir/munge-key/munge.key"
    rm -f "$key"
    head -c 1024 /dev/urandom > "$key"
    chmod 400 "$key"
    local socket="$dir/munge/munge.socket"
    "$munged" --key-file "$key" --socket "$socket" --pid-file "$dir/munge/munged.pid" \
        --log-file "$dir/munge/munged.log" --seed-file "$dir/munge/munged.seed" ||
        fail "munged did not start"
    # slurmd finds its own node by the short host name.
    local host user cpus
    host=$(cut -d. -f1 /proc/sys/kernel/hostname)
    user=$(id -un)
    cpus=$(nproc)
    cat > "$dir/slurm.conf" <<EOF
ClusterName=plsrlocal
SlurmctldHost=$host(127.0.0.1)
SlurmUser=$user
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
SchedulerParameters=sched_interval=1
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
    export SLURM_CONF="$dir/slurm.conf"
    "$slurmctld" -i || fail "slurmctld did not start"
    "$slurmd" || fail "slurmd did not start"
    local state="" waited=0
    while [ "$waited" -lt 240 ]; do
        state=$(sinfo -h -o %t 2>/dev/null || true)
        if [ "$state" = "idle" ]; then
            echo "a single-node Slurm cluster runs in $dir: export SLURM_CONF=$dir/slurm.conf"
            return
        fi
        sleep 0.25
        waited=$((waited + 1))
    done
    fail "the node did not become idle in 60 s (sinfo: '$state')"
}

stop() {
    [ -f "$dir/slurm.conf" ] || {
        echo "$0: $dir/slurm.conf does not exist: no cluster was started there" >&2
        exit 1
    }
    SLURM_CONF="$dir/slurm.conf" scontrol shutdown > /dev/null 2>&1 || true
    sleep 0.5
    local pid_file
    for pid_file in "$dir/slurmctld.pid" "$dir/slurmd.pid" "$dir/munge/munged.pid"; do
        if [ -f "$pid_file" ]; then
            kill "$(cat "$pid_file")" 2>/dev/null || true
        fi
    done
}

case "$action" in
    start) start ;;
    stop) stop ;;
    *) usage ;;
esac
