#!/bin/sh
# run.sh TARGET SECONDS - what `make fuzz` runs for one target (scene, obj, partial,
# mtl, pfm or exr) after building tests/out/fuzz/fuzz_TARGET:
#   1. replay the committed corpus tests/fuzz/corpus/TARGET (seeds and the
#      reproducers of past findings): every input must still pass;
#   2. unless SECONDS is 0, fuzz for SECONDS seconds from a scratch copy of
#      that corpus (tests/out/fuzz/corpus-TARGET; new inputs go there, never
#      into the committed corpus).
# libFuzzer's output goes to tests/out/fuzz/TARGET.log; on a crash, leak,
# timeout (10 s per input) or out-of-memory (2 GB) its tail is printed, the
# input is saved as tests/out/fuzz/TARGET-crash-... (or -leak-, -timeout-,
# -oom-) and the exit status is non-zero.
set -eu
target=$1
seconds=$2
out=tests/out/fuzz
bin=$out/fuzz_$target
log=$out/$target.log
work=$out/corpus-$target

# Longest input per format: a scene, an OBJ (with its MTL) or an MTL of a
# few hundred lines; a PFM header and a raster of up to ~1000 floats.
case $target in
    scene|obj) max_len=16384 ;;
    mtl) max_len=4096 ;;
    pfm) max_len=4096 ;;
    exr) max_len=4096 ;; # a header and a few ZIP or raw blocks
    partial) max_len=8192 ;; # a header and a few pixels' sums
    *) echo "run.sh: unknown target '$target'" >&2; exit 2 ;;
esac

export UBSAN_OPTIONS=print_stacktrace=1
opts="-rss_limit_mb=2048 -timeout=10 -dict=tests/fuzz/$target.dict -artifact_prefix=$out/$target-"

fail() {
    echo "fuzz_$target: $1 (log: $log)" >&2
    tail -n 60 "$log" >&2
    exit 1
}

# Files, not the directory, so that libFuzzer only runs them.
if ! "$bin" $opts "tests/fuzz/corpus/$target"/* >"$log" 2>&1; then
    fail "an input of the committed corpus fails"
fi
seeds=$(ls "tests/fuzz/corpus/$target" | wc -l)
if [ "$seconds" -eq 0 ]; then
    echo "fuzz_$target: the $seeds committed inputs pass"
    exit 0
fi
rm -rf "$work"
mkdir -p "$work"
cp "tests/fuzz/corpus/$target"/* "$work"/
if ! "$bin" $opts -max_len=$max_len -max_total_time="$seconds" -print_final_stats=1 "$work" >>"$log" 2>&1; then
    fail "libFuzzer found a problem"
fi
runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
echo "fuzz_$target: the $seeds committed inputs pass; $runs inputs in ${seconds} s, no crash, leak, timeout or OOM" \
     "(corpus now $(ls "$work" | wc -l) inputs)"
