#!/bin/sh
# tests/shards_slurm.sh [--install] [N]
#
# The README's Slurm recipe on a one-node cluster started here: munge and
# Debian's slurm-wlm (slurmctld + slurmd with a slurm.conf written under
# tests/out/slurm), a job array of N shards (sbatch --array=1-N), a merge
# job that waits for it (--dependency=afterok), and a check that the merged
# image is the render in one go, byte for byte. The daemons it started are
# stopped at the end.
#
# Exit status: 0 passed, 1 failed, 77 skipped: Slurm or munge is not
# installed (without --install), not running as root, or the daemons could
# not start in this container (the reason is printed; .ci/run reports it
# as skipped, not passed).
#
# --install: apt-get install slurm-wlm and munge if missing (CI).
# Cost: the installation (about 1 minute), then some 15 s.
set -eu
cd "$(dirname "$0")/.."
root=$(pwd)

install=0
if [ "${1:-}" = --install ]; then
    install=1
    shift
fi
N=${1:-2}

skip() {
    echo "shards_slurm: skipped: $*"
    exit 77
}

[ "$(id -u)" = 0 ] || skip "starting slurmctld, slurmd and munged needs root"
if ! command -v sbatch >/dev/null 2>&1 || ! command -v munged >/dev/null 2>&1; then
    [ $install = 1 ] || skip "slurm-wlm and munge are not installed (apt-get install slurm-wlm munge, or --install)"
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null ||
        skip "apt-get install slurm-wlm munge failed"
fi
make pds >/dev/null

dir=$root/tests/out/slurm
rm -rf "$dir"
mkdir -p "$dir/state" "$dir/spool" "$dir/munge"
host=$(hostname -s)
cpus=$(nproc)
pids=""
cleanup() {
    # (f, pid, n: plain variables, for any POSIX sh)
    for f in "$dir/slurmd.pid" "$dir/slurmctld.pid" "$dir/munge/munged.pid"; do
        [ -s "$f" ] || continue
        pid=$(cat "$f")
        kill "$pid" 2>/dev/null || continue
        # wait for it to go: slurmctld saves its state into $dir/state as
        # it stops, and a caller's `make clean` removing tests/out at the
        # same time failed ("Directory not empty"); at most 10 s
        n=0
        while kill -0 "$pid" 2>/dev/null && [ $n -lt 100 ]; do
            sleep 0.1
            n=$((n + 1))
        done
    done
}
trap cleanup EXIT INT TERM

# munge: its own key, socket and pid file under $dir (no system daemon touched)
dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 2>/dev/null
chmod 600 "$dir/munge/munge.key"
chmod 700 "$dir/munge"
socket=$dir/munge/munge.socket
munged --force --key-file="$dir/munge/munge.key" --socket="$socket" --pid-file="$dir/munge/munged.pid" \
    --log-file="$dir/munge/munged.log" --seed-file="$dir/munge/munged.seed" 2>"$dir/munge/start.err" ||
    skip "munged would not start: $(head -c 300 "$dir/munge/start.err")"

cat >"$dir/slurm.conf" <<EOF
ClusterName=pdstest
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
SlurmctldPort=16817
SlurmdPort=16818
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
NodeName=$host CPUs=$cpus State=UNKNOWN
PartitionName=pds Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$dir/slurm.conf

slurmctld -f "$SLURM_CONF" 2>"$dir/ctld.err" || skip "slurmctld would not start: $(head -c 300 "$dir/ctld.err")"
slurmd -f "$SLURM_CONF" 2>"$dir/d.err" || skip "slurmd would not start: $(head -c 300 "$dir/d.err")"
up=0
for i in $(seq 1 30); do
    if sinfo -h -o %T 2>/dev/null | grep -q idle; then
        up=1
        break
    fi
    sleep 1
done
[ $up = 1 ] || skip "the node did not come up in 30 s: $(tail -n 3 "$dir/slurmd.log" 2>/dev/null | tr '\n' ' ')"

# the recipe (README "Render farms"): a job array of shards, a merge job after it
args="scenes/refraction.scene --res 96x96 --spp 1 --photons 100000 --threads 1 --quiet"
array=$(sbatch --parsable --array=1-"$N" --chdir="$root" --output="$dir/shard-%a.log" \
    --wrap "./pds render $args --shard \$SLURM_ARRAY_TASK_ID/$N -o $dir/part-\$SLURM_ARRAY_TASK_ID.pdsp")
timeout 300 sbatch --wait --parsable --dependency=afterok:"$array" --chdir="$root" --output="$dir/merge.log" \
    --wrap "./pds merge -o $dir/merged.pfm $dir/part-*.pdsp" >/dev/null ||
    { echo "shards_slurm: FAIL: the merge job did not succeed: $(cat "$dir"/*.log | tail -n 5)"; exit 1; }

./pds render $args -o "$dir/single.pfm" >/dev/null
# the pixels, bit for bit (the files' metadata trailers hold times)
tests/pfm_pixels.sh "$dir/single.pfm" > "$dir/single.px"
tests/pfm_pixels.sh "$dir/merged.pfm" > "$dir/merged.px"
if ! cmp -s "$dir/single.px" "$dir/merged.px"; then
    echo "shards_slurm: FAIL: the merged image differs from the single run"
    exit 1
fi
echo "shards_slurm array=1-$N merged=$dir/merged.pfm identical=1"
