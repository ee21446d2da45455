#!/bin/sh
# tests/shards_parallel.sh [--install] [N]
#
# One render spread over N workers with GNU parallel, merged, and checked
# against the same render in one go: the merged image must be the same file
# byte for byte. The workers here are local (-j N); on a cluster the same
# command line takes --sshlogin host1,host2,... (and --basefile/--return to
# move the scene and the parts), as the README's recipe shows. Prints the
# wall-clock seconds of the single run, the sharded run and the merge.
#
# --install: apt-get install GNU parallel if it is missing (CI); without it
# a missing parallel is reported and the script exits 77 (skipped).
# Cost: about 3 x the render below, some 10 s on 2 cores.
set -eu
cd "$(dirname "$0")/.."

install=0
if [ "${1:-}" = --install ]; then
    install=1
    shift
fi
N=${1:-2}

if ! command -v parallel >/dev/null 2>&1; then
    if [ $install = 1 ]; then
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq parallel >/dev/null
    else
        echo "shards_parallel: skipped: GNU parallel is not installed (apt-get install parallel, or --install)"
        exit 77
    fi
fi
make pds >/dev/null

out=tests/out/parallel
rm -rf "$out"
mkdir -p "$out"
# the render: progressive PDS on the refraction case, one thread per worker
args="scenes/refraction.scene --res 128x128 --spp 1 --photons 300000 --threads 1 --quiet"

now() { date +%s.%N; }

t0=$(now)
./pds render $args -o "$out/single.pfm" >/dev/null
t1=$(now)
# shellcheck disable=SC2086
seq 1 "$N" | parallel --will-cite --halt now,fail=1 -j "$N" \
    ./pds render $args --shard {}/"$N" -o "$out/part{}.pdsp" >/dev/null
t2=$(now)
./pds merge -o "$out/merged.pfm" "$out"/part*.pdsp >/dev/null
t3=$(now)

# the pixels, bit for bit (the files' metadata trailers hold times)
tests/pfm_pixels.sh "$out/single.pfm" > "$out/single.px"
tests/pfm_pixels.sh "$out/merged.pfm" > "$out/merged.px"
if ! cmp -s "$out/single.px" "$out/merged.px"; then
    echo "shards_parallel: FAIL: the merged image differs from the single run"
    exit 1
fi
awk -v n="$N" -v a="$t0" -v b="$t1" -v c="$t2" -v d="$t3" 'BEGIN {
    printf "shards_parallel workers=%d single_s=%.2f sharded_s=%.2f speedup=%.2f merge_s=%.3f identical=1\n",
           n, b - a, c - b, (b - a) / (c - b), d - c }'
